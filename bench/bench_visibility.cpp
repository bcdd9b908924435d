// Visibility-backend benchmark: seconds per global direction versus patch count and
// map resolution. A benchmark, not a test: compare ratios measured in one run. Every
// configuration is measured `--repeat` times with the backends interleaved (so that a
// disturbance of the shared machine hits them alike); the fastest round is reported
// beside the median, and each backend's time as a ratio to the first backend's.
// Results and the commands that made them: docs/benchmarks.md.
//
//   bench_visibility [--backend exact-painter painter ...] [--scene cornell-box]
//                    [--patch-size 53 ...] [--resolution 256 512 1024]
//                    [--directions 200] [--repeat 5] [--csv out.csv]
//                    [--batch 16 [--threads 4]]
// --batch N hands the backends N directions at a time (Backend::transfer_many, what the
// solvers call: a GPU backend submits them together and prepares and sorts them on
// --threads threads; the CPU backends compute them in turn).
#include "sampling/directions.h"
#include "scenes/builtin.h"
#include "visibility/backend.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

namespace rb = raybundle;

namespace {

// Seconds per direction over `directions` directions (the same for every backend).
double measure(rb::visibility::Backend& backend, int directions, int batch, int threads, std::size_t& entries) {
    rb::sampling::RandomDirections dirs(7);
    rb::sampling::Rng jitter(7, 1);
    rb::visibility::GeometryMatrix m;
    std::vector<rb::visibility::GeometryMatrix> many;
    std::vector<rb::scenes::Vec3> ws;
    std::vector<Eigen::Vector2d> jitters;
    entries = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int d = 0; d < directions;) {
        if (batch <= 1) {
            backend.transfer(dirs.next(), {jitter.uniform(), jitter.uniform()}, m);
            entries += m.entries.size();
            ++d;
            continue;
        }
        ws.clear();
        jitters.clear();
        for (; d < directions && static_cast<int>(ws.size()) < batch; ++d) {
            ws.push_back(dirs.next());
            const double x = jitter.uniform(), y = jitter.uniform();
            jitters.emplace_back(x, y);
        }
        backend.transfer_many(ws, jitters, many, threads, {});
        for (const auto& g : many) entries += g.entries.size();
    }
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / directions;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybundle visibility benchmark"};
    std::vector<std::string> backends{"exact-painter"};
    std::string scene_name = "cornell-box";
    std::vector<double> patch_sizes;  // empty: the scene's default
    std::vector<int> resolutions{256, 512, 1024};
    int directions = 200;
    int repeat = 1;
    std::string csv;
    int batch = 1, threads = 1;
    app.add_option("--backend", backends, "backends to measure (ratios are to the first)")->capture_default_str();
    app.add_option("--scene", scene_name, "built-in scene")->capture_default_str();
    app.add_option("--patch-size", patch_sizes, "patch sizes (scene units), one scene each (default: the scene's)");
    app.add_option("--resolution", resolutions, "map resolutions")->capture_default_str();
    app.add_option("--directions", directions, "directions per measurement")->capture_default_str()->check(CLI::Range(1, 1 << 30));
    app.add_option("--repeat", repeat, "rounds per configuration, backends interleaved")->capture_default_str()->check(CLI::Range(1, 1000));
    app.add_option("--csv", csv, "write rows to this CSV");
    app.add_option("--batch", batch, "directions per transfer_many call (1: transfer, one at a time)")
        ->capture_default_str()->check(CLI::Range(1, 4096));
    app.add_option("--threads", threads, "threads a batch's CPU work may use")->capture_default_str()->check(CLI::Range(1, 1024));
    CLI11_PARSE(app, argc, argv);

    std::ofstream out;
    if (!csv.empty()) {
        out.open(csv);
        out << "backend,scene,patches,resolution,directions,repeat,seconds_per_direction,seconds_median,"
               "ratio_to_first,entries_per_direction,batch,threads\n";
    }
    std::printf("%-15s %-16s %8s %6s %12s %12s %8s %10s\n", "backend", "scene", "patches", "res", "ms (min)",
                "ms (median)", "ratio", "entries");
    std::vector<std::optional<double>> sizes;
    for (double ps : patch_sizes) sizes.emplace_back(ps);
    if (sizes.empty()) sizes.emplace_back(std::nullopt);
    for (const auto& ps : sizes) {
        const auto scene = rb::scenes::make_builtin(scene_name, ps);
        for (int res : resolutions) {
            rb::visibility::BackendOptions opt;
            opt.resolution = res;
            std::vector<std::unique_ptr<rb::visibility::Backend>> made;
            for (const auto& name : backends) {
                made.push_back(rb::visibility::make_backend(name, scene, opt));
                if (!made.back()->details().empty())
                    std::fprintf(stderr, "%s: %s\n", name.c_str(), made.back()->details().c_str());
                rb::visibility::GeometryMatrix m;  // warm-up: scratch allocation
                made.back()->transfer(rb::scenes::Vec3(0.6, 0.48, 0.64), {0.5, 0.5}, m);
            }
            std::vector<std::vector<double>> times(backends.size());
            std::vector<std::size_t> entries(backends.size());
            for (int r = 0; r < repeat; ++r)
                for (std::size_t b = 0; b < backends.size(); ++b)
                    times[b].push_back(measure(*made[b], directions, batch, threads, entries[b]));
            double first = 0.0;
            for (std::size_t b = 0; b < backends.size(); ++b) {
                auto t = times[b];
                std::sort(t.begin(), t.end());
                const double best = t.front(), median = t[t.size() / 2];
                if (b == 0) first = best;
                const double epd = static_cast<double>(entries[b]) / directions;
                std::printf("%-15s %-16s %8zu %6d %12.4f %12.4f %8.3f %10.0f\n", backends[b].c_str(),
                            scene_name.c_str(), scene.patch_count(), res, best * 1e3, median * 1e3, best / first,
                            epd);
                if (out)
                    out << backends[b] << ',' << scene_name << ',' << scene.patch_count() << ',' << res << ','
                        << directions << ',' << repeat << ',' << best << ',' << median << ',' << best / first << ','
                        << epd << ',' << batch << ',' << threads << '\n';
            }
        }
    }
    return 0;
}
