// Visibility-backend benchmark: seconds per global direction versus patch count and
// map resolution. A benchmark, not a test: run it on a quiet machine and compare
// ratios measured in one run. Results and the commands that made them: docs/benchmarks.md.
//
//   bench_visibility [--backend painter ...] [--scene cornell-box] [--patch-size 53 ...]
//                    [--resolution 256 512 1024] [--directions 200] [--csv out.csv]
#include "sampling/directions.h"
#include "scenes/builtin.h"
#include "visibility/backend.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>

namespace rb = raybundle;

int main(int argc, char** argv) {
    CLI::App app{"raybundle visibility benchmark"};
    std::vector<std::string> backends{"painter"};
    std::string scene_name = "cornell-box";
    std::vector<double> patch_sizes;  // empty: the scene's default
    std::vector<int> resolutions{256, 512, 1024};
    int directions = 200;
    std::string csv;
    app.add_option("--backend", backends, "backends to measure")->capture_default_str();
    app.add_option("--scene", scene_name, "built-in scene")->capture_default_str();
    app.add_option("--patch-size", patch_sizes, "patch sizes (scene units), one scene each (default: the scene's)");
    app.add_option("--resolution", resolutions, "map resolutions")->capture_default_str();
    app.add_option("--directions", directions, "directions per measurement")->capture_default_str();
    app.add_option("--csv", csv, "append rows to this CSV");
    CLI11_PARSE(app, argc, argv);

    std::ofstream out;
    if (!csv.empty()) {
        out.open(csv);
        out << "backend,scene,patches,resolution,directions,seconds_per_direction,entries_per_direction\n";
    }
    std::printf("%-10s %-16s %8s %6s %14s %10s\n", "backend", "scene", "patches", "res", "ms/direction", "entries");
    std::vector<std::optional<double>> sizes;
    for (double ps : patch_sizes) sizes.emplace_back(ps);
    if (sizes.empty()) sizes.emplace_back(std::nullopt);
    for (const auto& ps : sizes) {
        const auto scene = rb::scenes::make_builtin(scene_name, ps);
        for (const auto& name : backends)
            for (int res : resolutions) {
                rb::visibility::BackendOptions opt;
                opt.resolution = res;
                auto backend = rb::visibility::make_backend(name, scene, opt);
                if (!backend->details().empty()) std::fprintf(stderr, "%s: %s\n", name.c_str(), backend->details().c_str());
                rb::sampling::RandomDirections dirs(7);
                rb::sampling::Rng jitter(7, 1);
                rb::visibility::GeometryMatrix m;
                backend->transfer(dirs.next(), {0.5, 0.5}, m);  // warm-up: scratch allocation
                std::size_t entries = 0;
                const auto t0 = std::chrono::steady_clock::now();
                for (int d = 0; d < directions; ++d) {
                    backend->transfer(dirs.next(), {jitter.uniform(), jitter.uniform()}, m);
                    entries += m.entries.size();
                }
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                const double per = s / directions;
                const double epd = static_cast<double>(entries) / directions;
                std::printf("%-10s %-16s %8zu %6d %14.4f %10.0f\n", name.c_str(), scene_name.c_str(),
                            scene.patch_count(), res, per * 1e3, epd);
                if (out) out << name << ',' << scene_name << ',' << scene.patch_count() << ',' << res << ','
                             << directions << ',' << per << ',' << epd << '\n';
            }
    }
    return 0;
}
