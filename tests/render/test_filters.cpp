// Image filters: the guided filter against a direct evaluation of He et al.'s formulas
// and against OpenCV's cv::ximgproc::guidedFilter, its limits (constant guide, guide =
// input), thread-count independence, argument errors, and the edge behaviour of the
// cross bilateral and À-Trous filters.
#include "render/filters.h"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#ifdef RAYBUNDLE_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/ximgproc.hpp>
#endif

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>

using namespace raybundle;
using render::Guide;
using render::Image;

namespace {

Image random_image(int w, int h, unsigned seed, float lo = 0.0f, float hi = 1.0f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(lo, hi);
    Image img(w, h);
    for (float& v : img.rgb) v = u(rng);
    return img;
}

Guide random_guide(int w, int h, int channels, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Guide g(w, h, channels);
    for (float& v : g.data) v = u(rng);
    return g;
}

// OpenCV's BORDER_REFLECT, written out again from its definition (fedcba|abcdefgh|hgfedcb).
int reflect(int p, int n) {
    if (n == 1) return 0;
    while (p < 0 || p >= n) p = p < 0 ? -p - 1 : 2 * n - p - 1;
    return p;
}

// He et al.'s guided filter evaluated directly: every window summed pixel by pixel in
// double over the reflected image, the C×C system solved by Eigen's LDLᵀ.
Image reference_guided(const Image& p, const Guide& g, int r, const std::vector<double>& eps) {
    const int w = p.width, h = p.height, C = g.channels;
    const double n = (2.0 * r + 1) * (2.0 * r + 1);
    std::vector<Eigen::MatrixXd> a(static_cast<std::size_t>(w) * h);
    std::vector<Eigen::Vector3d> b(a.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            Eigen::VectorXd mu = Eigen::VectorXd::Zero(C);
            Eigen::MatrixXd S = Eigen::MatrixXd::Zero(C, C), IP = Eigen::MatrixXd::Zero(C, 3);
            Eigen::Vector3d pm = Eigen::Vector3d::Zero();
            for (int dy = -r; dy <= r; ++dy)
                for (int dx = -r; dx <= r; ++dx) {
                    const int xx = reflect(x + dx, w), yy = reflect(y + dy, h);
                    Eigen::VectorXd gi(C);
                    for (int c = 0; c < C; ++c) gi[c] = g.at(xx, yy)[c];
                    const Eigen::Vector3d pv(p.at(xx, yy)[0], p.at(xx, yy)[1], p.at(xx, yy)[2]);
                    mu += gi;
                    S += gi * gi.transpose();
                    pm += pv;
                    IP += gi * pv.transpose();
                }
            mu /= n;
            pm /= n;
            S = S / n - mu * mu.transpose();
            for (int c = 0; c < C; ++c) S(c, c) += eps.size() == 1 ? eps[0] : eps[c];
            const Eigen::MatrixXd cov = IP / n - mu * pm.transpose();
            const std::size_t k = static_cast<std::size_t>(y) * w + x;
            a[k] = S.ldlt().solve(cov);  // C×3
            b[k] = pm - a[k].transpose() * mu;
        }
    Image out(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            Eigen::MatrixXd am = Eigen::MatrixXd::Zero(C, 3);
            Eigen::Vector3d bm = Eigen::Vector3d::Zero();
            for (int dy = -r; dy <= r; ++dy)
                for (int dx = -r; dx <= r; ++dx) {
                    const std::size_t k = static_cast<std::size_t>(reflect(y + dy, h)) * w + reflect(x + dx, w);
                    am += a[k];
                    bm += b[k];
                }
            Eigen::VectorXd gi(C);
            for (int c = 0; c < C; ++c) gi[c] = g.at(x, y)[c];
            const Eigen::Vector3d q = (am.transpose() * gi + bm) / n;
            for (int c = 0; c < 3; ++c) out.at(x, y)[c] = static_cast<float>(q[c]);
        }
    return out;
}

// Largest |a − b| over the pixels at least `margin` away from every border.
double max_diff(const Image& a, const Image& b, int margin = 0) {
    double m = 0.0;
    for (int y = margin; y < a.height - margin; ++y)
        for (int x = margin; x < a.width - margin; ++x)
            for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(static_cast<double>(a.at(x, y)[c]) - b.at(x, y)[c]));
    return m;
}

bool bit_identical(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height &&
           std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

Guide channel_as_guide(const Image& img, int channel) {
    Guide g(img.width, img.height, 1);
    for (std::size_t i = 0; i < g.data.size(); ++i) g.data[i] = img.rgb[3 * i + channel];
    return g;
}

}  // namespace

TEST_CASE("guided filter equals a direct evaluation of He et al.'s formulas", "[filters]") {
    const int channels = GENERATE(1, 3, 4);
    const int r = GENERATE(1, 3, 9, 20);  // 9 and 20 reach past the 17-row image: repeated reflection
    const float outlier = GENERATE(0.0f, 1e4f);  // a firefly: the quanta grow with the range
    Image p = random_image(23, 17, 11, -0.5f, 2.0f);
    if (outlier > 0) p.at(11, 8)[1] = outlier;
    Guide g = random_guide(23, 17, channels, 12);
    for (std::size_t i = channels - 1; i < g.data.size(); i += channels) g.data[i] += 40.0f;  // depth far away
    std::vector<double> eps{0.02};
    if (channels == 4) eps = {0.01, 0.01, 0.01, 0.03};  // 003 §4: normals 0.01, depth 0.01-0.03
    INFO("channels " << channels << ", radius " << r << ", outlier " << outlier);
    const Image ours = render::guided_filter(p, g, r, eps);
    const Image ref = reference_guided(p, g, r, eps);
    double err = 0.0;  // relative to the value, or absolute below 1
    for (std::size_t i = 0; i < ours.rgb.size(); ++i)
        err = std::max(err, std::abs(static_cast<double>(ours.rgb[i]) - ref.rgb[i]) / std::max(1.0f, std::abs(ref.rgb[i])));
    CHECK(err < 1e-6);  // float rounding of the output: both work in double
    // The result is not the input, nor a plain box mean: the test can tell.
    CHECK(max_diff(ours, p) > 0.05);
}

TEST_CASE("guided filter: one eps for all channels equals the same eps given per channel", "[filters]") {
    const Image p = random_image(40, 30, 3);
    const Guide g = random_guide(40, 30, 4, 4);
    CHECK(bit_identical(render::guided_filter(p, g, 5, 0.01), render::guided_filter(p, g, 5, {0.01, 0.01, 0.01, 0.01})));
    CHECK(!bit_identical(render::guided_filter(p, g, 5, 0.01), render::guided_filter(p, g, 5, {0.01, 0.01, 0.01, 0.03})));
}

#ifdef RAYBUNDLE_HAVE_OPENCV
TEST_CASE("guided filter matches cv::ximgproc::guidedFilter", "[filters][opencv]") {
    const int channels = GENERATE(1, 3);
    const int r = GENERATE(2, 5, 8, 16);
    const double eps = GENERATE(0.001, 0.01, 0.1);
    const int w = 160, h = 120;
    const Image p = random_image(w, h, 21);
    const Guide g = random_guide(w, h, channels, 22);
    const cv::Mat src(h, w, CV_32FC3, const_cast<float*>(p.rgb.data()));
    const cv::Mat guide(h, w, CV_MAKETYPE(CV_32F, channels), const_cast<float*>(g.data.data()));
    cv::Mat dst;
    cv::ximgproc::guidedFilter(guide, src, dst, r, eps, -1);
    REQUIRE(dst.type() == CV_32FC3);
    REQUIRE(dst.isContinuous());
    Image cv_out(w, h);
    std::memcpy(cv_out.rgb.data(), dst.ptr<float>(0), cv_out.rgb.size() * sizeof(float));

    const Image ours = render::guided_filter(p, g, r, eps);
    INFO("channels " << channels << ", radius " << r << ", eps " << eps);
    CHECK(max_diff(ours, cv_out, r) < 1e-4);  // interior: the requirement
    CHECK(max_diff(ours, cv_out) < 1e-4);     // and the borders too: both use BORDER_REFLECT
}
#endif

TEST_CASE("guided filter with a constant guide is a box mean of box means", "[filters]") {
    // a = 0 in every window, so b = the window mean of the input, and the output is the
    // mean of those: the box filter applied twice (reflected borders).
    const int w = 31, h = 26, r = GENERATE(1, 4, 12);
    const Image p = random_image(w, h, 5);
    Guide g(w, h, GENERATE(1, 3, 4));
    std::fill(g.data.begin(), g.data.end(), 0.37f);
    auto box = [&](const Image& in) {
        Image out(w, h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c) {
                    double s = 0.0;
                    for (int dy = -r; dy <= r; ++dy)
                        for (int dx = -r; dx <= r; ++dx) s += in.at(reflect(x + dx, w), reflect(y + dy, h))[c];
                    out.at(x, y)[c] = static_cast<float>(s / ((2.0 * r + 1) * (2.0 * r + 1)));
                }
        return out;
    };
    INFO("radius " << r << ", channels " << g.channels);
    CHECK(max_diff(render::guided_filter(p, g, r, 0.01), box(box(p))) < 1e-6);
}

TEST_CASE("guided filter with the input as its guide returns the input as eps goes to 0", "[filters]") {
    const Image p = random_image(48, 36, 9);
    double previous = 1e9;
    for (double eps : {1e-2, 1e-4, 1e-6}) {
        double err = 0.0;
        for (int c = 0; c < 3; ++c) {
            const Image q = render::guided_filter(p, channel_as_guide(p, c), 4, eps);
            for (std::size_t i = 0; i < q.rgb.size() / 3; ++i)
                err = std::max(err, std::abs(static_cast<double>(q.rgb[3 * i + c]) - p.rgb[3 * i + c]));
        }
        INFO("eps " << eps);
        CHECK(err < previous);
        previous = err;
        if (eps == 1e-2) CHECK(err > 1e-3);  // still visibly smoothing
        if (eps == 1e-6) CHECK(err < 1e-4);
    }
}

TEST_CASE("filters give bit-identical results for every thread count", "[filters]") {
    const int w = 67, h = 45;
    const Image p = random_image(w, h, 31, 0.0f, 5.0f);
    for (int channels : {1, 3, 4}) {
        const Guide g = random_guide(w, h, channels, 32);
        const Image one = render::guided_filter(p, g, 7, 0.01, 1);
        for (int t : {2, 3, 8, 64}) {
            INFO("guided, channels " << channels << ", threads " << t);
            CHECK(bit_identical(one, render::guided_filter(p, g, 7, 0.01, t)));
        }
    }
    // An outlier 1e12 times brighter than the rest passes through band 1's running sums
    // only: sums that drifted with the path (instead of being exact) would show below it.
    Image outlier = random_image(40, 96, 35, 0.0f, 1e-3f);
    for (int x = 10; x < 14; ++x) outlier.at(x, 3)[0] = 1e9f;
    const Guide go = random_guide(40, 96, 3, 36);
    const Image base = render::guided_filter(outlier, go, 2, 0.01, 1);
    for (int t : {2, 3, 5}) {
        INFO("guided with an outlier, threads " << t);
        CHECK(bit_identical(base, render::guided_filter(outlier, go, 2, 0.01, t)));
    }
    const Guide g4 = random_guide(w, h, 4, 33), g6 = random_guide(w, h, 6, 34);
    const Image bil = render::cross_bilateral_filter(p, g4, 3, 2.0, 0.3, 0.3, 1);
    const Image atr = render::atrous_filter(p, g6, 4, 1.0, 0.3, 0.3, 1);
    for (int t : {2, 3, 8}) {
        INFO("threads " << t);
        CHECK(bit_identical(bil, render::cross_bilateral_filter(p, g4, 3, 2.0, 0.3, 0.3, t)));
        CHECK(bit_identical(atr, render::atrous_filter(p, g6, 4, 1.0, 0.3, 0.3, t)));
    }
}

TEST_CASE("filters reject bad arguments with one line naming the parameter", "[filters]") {
    const Image p = random_image(10, 8, 1);
    const Guide g1 = random_guide(10, 8, 1, 2), g4 = random_guide(10, 8, 4, 3);
    using Catch::Contains;
    REQUIRE_THROWS_AS(render::guided_filter(p, random_guide(10, 9, 1, 2), 2, 0.01), std::invalid_argument);
    CHECK_THROWS_WITH(render::guided_filter(p, random_guide(10, 9, 1, 2), 2, 0.01),
                      Contains("guide size 10x9 differs from input size 10x8"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 0, 0.01), Contains("radius 0 < 1"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 1025, 0.01), Contains("radius 1025 > 1024"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 2, std::numeric_limits<double>::infinity()),
                      Contains("eps inf is not finite"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 2, 0.0), Contains("eps 0 <= 0"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 2, -0.5), Contains("eps -0.5 <= 0"));
    CHECK_THROWS_WITH(render::guided_filter(p, g4, 2, {0.01, 0.01, 0.01, 0.0}), Contains("eps 0 <= 0"));
    CHECK_THROWS_WITH(render::guided_filter(p, g4, 2, {0.01, 0.02}), Contains("eps has 2 values"));
    CHECK_THROWS_WITH(render::guided_filter(p, random_guide(10, 8, 2, 4), 2, 0.01),
                      Contains("guide channels 2 not in {1, 3, 4}"));
    CHECK_THROWS_WITH(render::guided_filter(p, g1, 2, 0.01, 0), Contains("threads 0 < 1"));
    Guide short_guide = g1;
    short_guide.data.pop_back();
    CHECK_THROWS_WITH(render::guided_filter(p, short_guide, 2, 0.01), Contains("holds 79 floats"));
    Image bad = p;
    bad.at(3, 5)[1] = std::nanf("");
    CHECK_THROWS_WITH(render::guided_filter(bad, g1, 2, 0.01), Contains("input value nan at pixel (3, 5) channel 1"));
    Guide bad_guide = random_guide(5, 3, 3, 7);  // 45 floats: the last ones are scanned one by one
    bad_guide.at(4, 2)[2] = std::numeric_limits<float>::infinity();
    CHECK_THROWS_WITH(render::guided_filter(random_image(5, 3, 8), bad_guide, 1, 0.01),
                      Contains("guide value inf at pixel (4, 2) channel 2"));

    CHECK_THROWS_WITH(render::cross_bilateral_filter(p, g4, 0, 1.0, 0.1, 0.1), Contains("radius 0 < 1"));
    CHECK_THROWS_WITH(render::cross_bilateral_filter(p, g4, 2, 0.0, 0.1, 0.1), Contains("sigma_spatial 0"));
    CHECK_THROWS_WITH(render::cross_bilateral_filter(p, random_guide(10, 8, 6, 5), 2, 1.0, 0.1, 0.1),
                      Contains("guide channels 6 not in {1, 3, 4}"));
    CHECK_THROWS_WITH(render::atrous_filter(p, g4, 0, 1.0, 0.1, 0.1), Contains("iterations 0 not in [1, 16]"));
    CHECK_THROWS_WITH(render::atrous_filter(p, g4, 17, 1.0, 0.1, 0.1), Contains("iterations 17 not in [1, 16]"));
    CHECK_THROWS_WITH(render::atrous_filter(p, g4, 3, 1.0, -1.0, 0.1), Contains("sigma_normal -1"));
    CHECK_THROWS_WITH(render::atrous_filter(p, random_guide(10, 8, 5, 6), 3, 1.0, 0.1, 0.1),
                      Contains("guide channels 5 not in {1, 3, 4, 6}"));
    CHECK_THROWS_WITH(render::atrous_filter(p, random_guide(10, 7, 4, 6), 3, 1.0, 0.1, 0.1),
                      Contains("differs from input size"));
}

namespace {

// A scene-like pair: two planes meeting at column w/2 (normals (0,0,1) | (1,0,0), the
// same depth), the input 0.2 on the left and 1.0 on the right, plus noise of ±`noise`.
struct EdgeScene {
    Image input;
    Guide guide, flat;  // flat: the same normal everywhere
};

EdgeScene edge_scene(int w, int h, float noise, int channels) {
    std::mt19937 rng(77);
    std::uniform_real_distribution<float> u(-noise, noise);
    EdgeScene s{Image(w, h), Guide(w, h, channels), Guide(w, h, channels)};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool left = x < w / 2;
            for (int c = 0; c < 3; ++c) s.input.at(x, y)[c] = (left ? 0.2f : 1.0f) + u(rng);
            float* g = s.guide.at(x, y);
            float* f = s.flat.at(x, y);
            g[0] = left ? 0.0f : 1.0f;
            g[2] = left ? 1.0f : 0.0f;
            f[2] = 1.0f;
            for (int c = 3; c < channels; ++c) g[c] = f[c] = 2.0f;  // depth or position: the same
        }
    return s;
}

// Largest |value − 0.2| left of the edge, where nothing from the right may arrive.
double left_leak(const Image& img) {
    double m = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width / 2; ++x)
            for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(img.at(x, y)[c] - 0.2));
    return m;
}

double stddev(const Image& img) {
    double s = 0.0, s2 = 0.0;
    for (float v : img.rgb) {
        s += v;
        s2 += static_cast<double>(v) * v;
    }
    const double n = static_cast<double>(img.rgb.size());
    return std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
}

}  // namespace

TEST_CASE("cross bilateral and À-Trous filters keep constants, respect guide edges, remove noise", "[filters]") {
    const int w = 40, h = 24;
    using Filter = std::function<Image(const Image&, const Guide&)>;
    // Colour sigmas large enough that only the guide can stop the blur at the edge.
    const std::vector<std::pair<std::string, Filter>> filters{
        {"bilateral", [](const Image& p, const Guide& g) { return render::cross_bilateral_filter(p, g, 5, 3.0, 0.1, 0.1); }},
        {"atrous-4", [](const Image& p, const Guide& g) { return render::atrous_filter(p, g, 4, 100.0, 0.1, 0.1); }},
        {"atrous-6", [](const Image& p, const Guide& g) { return render::atrous_filter(p, g, 6, 100.0, 0.1, 0.1); }},
    };
    for (const auto& [name, filter] : filters) {
        const int channels = name == "bilateral" ? 4 : 6;
        INFO(name);
        // A constant image stays constant whatever the guide.
        Image constant(w, h);
        for (std::size_t i = 0; i < constant.rgb.size(); ++i) constant.rgb[i] = i % 3 == 0 ? 0.7f : 0.25f;
        CHECK(max_diff(filter(constant, random_guide(w, h, channels, 8)), constant) < 1e-6);

        // The noise goes; nothing crosses the edge in the guide.
        const EdgeScene noisy = edge_scene(w, h, 0.05f, channels);
        const Image out = filter(noisy.input, noisy.guide);
        CHECK(left_leak(out) < 0.06);
        CHECK(left_leak(noisy.input) < 0.06);
        Image left_half(w / 2, h), left_half_in(w / 2, h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w / 2; ++x)
                for (int c = 0; c < 3; ++c) {
                    left_half.at(x, y)[c] = out.at(x, y)[c];
                    left_half_in.at(x, y)[c] = noisy.input.at(x, y)[c];
                }
        CHECK(stddev(left_half) < stddev(left_half_in) / 3);
        // Control: with a flat guide the same filter does blur across the edge.
        CHECK(left_leak(filter(noisy.input, noisy.flat)) > 0.1);

        // A step in the image that matches a step in the guide stays a step.
        const EdgeScene step = edge_scene(w, h, 0.0f, channels);
        CHECK(max_diff(filter(step.input, step.guide), step.input) < 1e-5);
    }
}

TEST_CASE("the À-Trous filter's colour term alone keeps a strong step", "[filters]") {
    const EdgeScene step = edge_scene(40, 24, 0.0f, 4);
    // Flat guide: only the colour weight (σ 0.05 against a step of 0.8) stops the blur.
    CHECK(max_diff(render::atrous_filter(step.input, step.flat, 5, 0.05, 0.1, 0.1), step.input) < 1e-5);
    CHECK(max_diff(render::atrous_filter(step.input, step.flat, 5, 100.0, 0.1, 0.1), step.input) > 0.1);
}
