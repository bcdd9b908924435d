// The resolution study of 004 section 5.2 (Table 2), redone with and without the
// jittered grid: the residual error of stochastic iteration on a visibility map of
// R x R pixels, against a reference solved on a fine jittered map.
//
// Every run uses the same seed, hence the same directions (common random numbers):
// the differences between runs come from the map, not from the direction sampling.
// The residual error is the relative L1 difference of the patch radiances,
// sum area |L - L_ref| / sum area L_ref over patches and channels.
//
// At a fixed number of iterations that error is mostly pixel noise (a patch of a few
// pixels is hit or missed by whole pixels in every direction), not bias. To separate
// the two, each jittered resolution up to --streams-up-to is also solved with K
// independent jitter streams for the same directions: the error of their mean falls as
// 1/sqrt(K) where it is noise and stays where it is bias.
//
//   resolution_study [--scene cornell-box] [--resolution 50 100 200 500 1000]
//                    [--reference 1000] [--iterations 10000] [--seed 1] [--csv out.csv]
#include "scenes/builtin.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>

namespace rb = raybundle;

namespace {

struct Result {
    rb::solver::RadianceField field;
    double seconds_per_iteration;
};

struct Method {
    bool bidirectional = true;
    bool diffuse_shot = false;
};

Result solve(const rb::scenes::Scene& scene, int resolution, bool jitter, long iterations, std::uint64_t seed,
             const Method& method, std::uint64_t stream = 0) {
    rb::visibility::BackendOptions opt;
    opt.resolution = resolution;
    opt.jitter = jitter;
    auto backend = rb::visibility::make_backend("painter", scene, opt);
    rb::solver::SolverOptions it_opt;
    rb::sampling::RunOptions it_opt_run;
    it_opt.steps = iterations;
    it_opt_run.seed = seed;
    it_opt_run.jitter_stream = stream;
    it_opt.both_ways = method.bidirectional;
    const rb::solver::Transport transport(scene, rb::solver::ShotOptions{method.diffuse_shot});
    rb::solver::StochasticIteration it(transport, *backend, it_opt, it_opt_run);
    const auto t0 = std::chrono::steady_clock::now();
    it.run();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return {it.field(), s / static_cast<double>(iterations)};
}

double residual(const rb::scenes::Scene& scene, const rb::solver::RadianceField& a,
                const rb::solver::RadianceField& ref) {
    double err = 0.0, norm = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        err += scene.patch_list()[i].area * (a.radiance[i] - ref.radiance[i]).abs().sum();
        norm += scene.patch_list()[i].area * ref.radiance[i].sum();
    }
    return err / norm;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybundle resolution study (004 section 5.2, Table 2)"};
    std::string scene_name = "cornell-box";
    std::vector<int> resolutions{50, 100, 200, 500, 1000};
    int reference_resolution = 1000;
    long iterations = 10000;
    std::uint64_t seed = 1;
    std::string csv;
    int streams = 8, streams_up_to = 200;
    app.add_option("--streams", streams, "jitter streams averaged per resolution")->capture_default_str();
    app.add_option("--streams-up-to", streams_up_to, "average streams only up to this resolution")
        ->capture_default_str();
    app.add_option("--scene", scene_name, "built-in scene")->capture_default_str();
    app.add_option("--resolution", resolutions, "map resolutions")->capture_default_str();
    app.add_option("--reference", reference_resolution, "resolution of the jittered reference")->capture_default_str();
    app.add_option("--iterations", iterations, "iterations per run")->capture_default_str();
    app.add_option("--seed", seed, "seed shared by every run")->capture_default_str();
    app.add_option("--csv", csv, "write the table as CSV");
    Method method;
    app.add_flag("--both-ways,!--one-way", method.bidirectional, "use w and -w per step (default)");
    app.add_flag("--diffuse-shot", method.diffuse_shot, "compute the area light's direct light once");
    CLI11_PARSE(app, argc, argv);

    const auto scene = rb::scenes::make_builtin(scene_name);
    double mean_area = scene.total_area() / static_cast<double>(scene.patch_count());
    std::fprintf(stderr, "reference: %d^2, jittered, %ld iterations\n", reference_resolution, iterations);
    const Result ref = solve(scene, reference_resolution, true, iterations, seed, method);

    std::ofstream out;
    if (!csv.empty()) {
        out.open(csv);
        out << "resolution,pixels_per_patch,jitter,residual_error,residual_error_mean_of_streams,streams,"
               "seconds_per_iteration\n";
    }
    std::printf("%10s %16s %8s %15s %22s %14s\n", "resolution", "pixels/patch", "jitter", "residual error",
                "mean of K streams (K)", "ms/iteration");
    for (const int r : resolutions)
        for (const bool jitter : {false, true}) {
            const Result run = (jitter && r == reference_resolution) ? ref : solve(scene, r, jitter, iterations, seed, method);
            const double pixel = 2.0 * scene.bounds_radius() / r;
            // The mean projected patch over all directions is half its area (mean |cos| = 1/2).
            const double ppp = 0.5 * mean_area / (pixel * pixel);
            const double e = residual(scene, run.field, ref.field);
            // The mean over K jitter streams (the first is the run above).
            int k_used = 1;
            double e_mean = e;
            if (jitter && r <= streams_up_to && r != reference_resolution && streams > 1) {
                rb::solver::RadianceField mean = run.field;
                for (int k = 1; k < streams; ++k) {
                    const Result more = solve(scene, r, true, iterations, seed, method, static_cast<std::uint64_t>(k));
                    for (std::size_t i = 0; i < mean.radiance.size(); ++i) mean.radiance[i] += more.field.radiance[i];
                }
                for (auto& L : mean.radiance) L /= static_cast<double>(streams);
                k_used = streams;
                e_mean = residual(scene, mean, ref.field);
            }
            std::printf("%10d %16.2f %8s %15.4f %17.4f (%2d) %14.3f\n", r, ppp, jitter ? "yes" : "no", e, e_mean,
                        k_used, run.seconds_per_iteration * 1e3);
            std::fflush(stdout);
            if (out) out << r << ',' << ppp << ',' << (jitter ? "yes" : "no") << ',' << e << ',' << e_mean << ','
                         << k_used << ',' << run.seconds_per_iteration << '\n';
        }
    return 0;
}
