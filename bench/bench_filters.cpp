// Image-filter benchmark (003 Table 2): milliseconds per filtering of one RGB image by
// our guided filter (1-, 3- and 4-channel guides), OpenCV's cv::ximgproc::guidedFilter
// (1- and 3-channel guides, when OpenCV was found at configure time), our cross
// bilateral filter and our À-Trous filter, at 1, 2, ... threads. Every configuration
// runs once per repetition, the repetitions interleaved, so that a disturbance of the
// machine hits all of them alike; the CSV on stdout gives the fastest and the median
// repetition. A benchmark, not a test: results and the command are in docs/benchmarks.md.
//
//   bench_filters [--filters guided opencv-guided bilateral atrous] [--width 1024]
//                 [--height 768] [--repetitions 7] [--radius 8 24 32] [--threads 1 2]
//                 [--bilateral-radius 8] [--atrous-iterations 4 5 6]
#include "render/filters.h"

#include <CLI/CLI.hpp>

#ifdef RAYBUNDLE_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/ximgproc.hpp>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace rb = raybundle;
using rb::render::Guide;
using rb::render::Image;

namespace {

// A G-buffer-like guide and a noisy input: a floor, a back wall and a tilted box, with
// their unit normals, depth, and smooth shading plus uniform noise (a 1-spp estimate).
struct Scene {
    Image noisy;
    Guide depth, normal, normal_depth;
};

Scene make_scene(int w, int h) {
    Scene s{Image(w, h), Guide(w, h, 1), Guide(w, h, 3), Guide(w, h, 4)};
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> noise(0.0f, 2.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
            float n[3], z;
            if (std::abs(u - 0.6f) < 0.15f && std::abs(v - 0.55f) < 0.2f) {  // the box
                const float t = 0.5f;
                n[0] = std::sin(t), n[1] = 0.0f, n[2] = std::cos(t);
                z = 3.0f + (u - 0.6f);
            } else if (v > 0.65f) {  // the floor
                n[0] = 0.0f, n[1] = 1.0f, n[2] = 0.0f;
                z = 1.0f + 4.0f * (1.0f - v);
            } else {  // the wall
                n[0] = 0.0f, n[1] = 0.0f, n[2] = 1.0f;
                z = 5.0f;
            }
            *s.depth.at(x, y) = z / 5.0f;
            for (int c = 0; c < 3; ++c) s.normal.at(x, y)[c] = s.normal_depth.at(x, y)[c] = n[c];
            s.normal_depth.at(x, y)[3] = z / 5.0f;
            const float shade = 0.3f + 0.5f * n[1] + 0.2f * u;
            float* p = s.noisy.at(x, y);
            p[0] = shade * noise(rng);
            p[1] = 0.8f * shade * noise(rng);
            p[2] = 0.6f * shade * noise(rng);
        }
    return s;
}

struct Config {
    std::string filter;
    int guide_channels, size, threads;  // size: radius, or iterations for À-Trous
    std::function<void()> run;
    std::vector<double> ms;
    std::function<void()> prepare = [] {};  // before the clock starts
};

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybundle image-filter benchmark"};
    int width = 1024, height = 768, repetitions = 7;
    std::vector<int> radii{8, 24, 32}, threads{1, 2}, bilateral_radii{8}, atrous_iterations{4, 5, 6};
    std::vector<std::string> filters{"guided", "opencv-guided", "bilateral", "atrous"};
    app.add_option("--filters", filters, "filters to measure")
        ->check(CLI::IsMember({"guided", "opencv-guided", "bilateral", "atrous"}))
        ->capture_default_str();
    app.add_option("--width", width, "image width")->capture_default_str();
    app.add_option("--height", height, "image height")->capture_default_str();
    app.add_option("--repetitions", repetitions, "interleaved runs of every configuration")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    app.add_option("--radius", radii, "guided-filter radii")->capture_default_str();
    app.add_option("--threads", threads, "thread counts")->capture_default_str();
    app.add_option("--bilateral-radius", bilateral_radii, "cross-bilateral radii")->capture_default_str();
    app.add_option("--atrous-iterations", atrous_iterations, "À-Trous iteration counts")->capture_default_str();
    CLI11_PARSE(app, argc, argv);

    const Scene scene = make_scene(width, height);
    const std::vector<double> eps4{0.01, 0.01, 0.01, 0.02};  // 003 §4: normals 0.01, depth 0.01-0.03
    auto wanted = [&](const char* name) { return std::find(filters.begin(), filters.end(), name) != filters.end(); };
    std::vector<Config> configs;
    for (int t : threads) {
        for (int r : radii) {
            if (wanted("guided")) {
                configs.push_back({"guided", 1, r, t, [&, r, t] { rb::render::guided_filter(scene.noisy, scene.depth, r, 0.01, t); }, {}});
                configs.push_back({"guided", 3, r, t, [&, r, t] { rb::render::guided_filter(scene.noisy, scene.normal, r, 0.01, t); }, {}});
                configs.push_back({"guided", 4, r, t, [&, r, t] { rb::render::guided_filter(scene.noisy, scene.normal_depth, r, eps4, t); }, {}});
            }
#ifdef RAYBUNDLE_HAVE_OPENCV
            if (wanted("opencv-guided"))
                for (int c : {1, 3})
                    configs.push_back({"opencv-guided", c, r, t, [&, r, t, c] {
                                       const cv::Mat src(height, width, CV_32FC3, const_cast<float*>(scene.noisy.rgb.data()));
                                       const Guide& g = c == 1 ? scene.depth : scene.normal;
                                       const cv::Mat guide(height, width, CV_MAKETYPE(CV_32F, c), const_cast<float*>(g.data.data()));
                                       cv::Mat dst;
                                       cv::ximgproc::guidedFilter(guide, src, dst, r, 0.01, -1);
                                   }, {}, [t] { cv::setNumThreads(t); }});
#endif
        }
        if (wanted("bilateral"))
            for (int r : bilateral_radii)
                configs.push_back({"bilateral", 4, r, t, [&, r, t] {
                                       rb::render::cross_bilateral_filter(scene.noisy, scene.normal_depth, r, r / 2.0, 0.1, 0.05, t);
                                   }, {}});
        if (wanted("atrous"))
            for (int n : atrous_iterations)
                configs.push_back({"atrous", 4, n, t, [&, n, t] {
                                       rb::render::atrous_filter(scene.noisy, scene.normal_depth, n, 1.0, 0.1, 0.05, t);
                                   }, {}});
    }
#ifndef RAYBUNDLE_HAVE_OPENCV
    std::fprintf(stderr, "bench_filters: built without OpenCV: no opencv-guided rows\n");
#endif

    for (auto& c : configs) {  // warm-up: page in the code and the images
        c.prepare();
        c.run();
    }
    for (int rep = 0; rep < repetitions; ++rep)
        for (auto& c : configs) {
            c.prepare();
            const auto t0 = std::chrono::steady_clock::now();
            c.run();
            c.ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }

    std::printf("filter,guide_channels,radius_or_iterations,threads,width,height,ms_min,ms_median,repetitions\n");
    for (auto& c : configs) {
        std::sort(c.ms.begin(), c.ms.end());
        std::printf("%s,%d,%d,%d,%d,%d,%.2f,%.2f,%d\n", c.filter.c_str(), c.guide_channels, c.size, c.threads, width,
                    height, c.ms.front(), c.ms[c.ms.size() / 2], repetitions);
    }
}
