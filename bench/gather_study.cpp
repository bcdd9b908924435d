// The final gather's error against a high-sample reference of our own (003 Fig. 8 and
// the user's "run time against error"), on the Cornell box.
//
//   gather_study filters  [--size 128] [--spp 1] ...   every filter over a parameter
//                                                      sweep: filter,params,mse,seconds
//   gather_study pipeline [--size 128] ...             solve + gather for several step
//                                                      counts and gather rays (= direct
//                                                      samples), unfiltered and guided
//
// The reference: 20,000 steps with the diffuse shot, 2,048 gather rays, 256 direct
// samples, no filter. MSE over pixels and channels of the final image.
#include "render/camera.h"
#include "render/final_gather.h"
#include "render/metrics.h"
#include "scenes/builtin.h"
#include "scenes/ray_caster.h"
#include "solver/solver.h"
#include "visibility/backend.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <string>

using namespace raybundle;
using Clock = std::chrono::steady_clock;

namespace {

solver::RadianceField solve(const scenes::Scene& scene, long steps, double& seconds) {
    const auto t0 = Clock::now();
    const solver::Transport transport(scene, solver::ShotOptions{true});
    solver::SolverOptions options;  // stochastic iteration, the default backend
    options.steps = steps;
    sampling::RunOptions run;
    run.seed = 99;
    const auto it = solver::make_solver(transport, options, run);
    it->run();
    seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return it->field();
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"final-gather error studies on the Cornell box"};
    app.require_subcommand(1);
    int size = 128, spp = 1, threads = 1, gather = 16, direct = 16, ref_gather = 2048;
    std::string only;
    double patch_size = 53.0;
    long reference_steps = 20000;
    app.add_option("--size", size, "image width and height")->capture_default_str();
    app.add_option("--patch-size", patch_size, "Cornell box patch size (mm)")->capture_default_str();
    app.add_option("--threads", threads, "threads for the gather and filters")->capture_default_str();
    app.add_option("--reference-steps", reference_steps, "solver steps of the reference")->capture_default_str();
    auto* filters = app.add_subcommand("filters", "every filter over a parameter sweep");
    filters->add_option("--spp", spp, "camera samples per pixel")->capture_default_str();
    filters->add_option("--gather", gather, "gather rays per guide")->capture_default_str();
    filters->add_option("--direct", direct, "direct-light samples")->capture_default_str();
    filters->add_option("--ref-gather", ref_gather, "gather rays of the reference")->capture_default_str();
    filters->add_option("--only", only, "sweep one filter only: guided | bilateral | atrous");
    app.add_subcommand("pipeline", "run time against error for the whole pipeline");
    CLI11_PARSE(app, argc, argv);
    sampling::RunOptions run;
    run.threads = threads;

    auto scene = scenes::make_builtin("cornell-box", patch_size);
    scene.camera.width = scene.camera.height = size;
    const scenes::RayCaster caster(scene);
    const render::PinholeCamera camera(scene.camera);
    double seconds_ref = 0.0;
    const auto ref_field = solve(scene, reference_steps, seconds_ref);

    if (filters->parsed()) {
        render::GatherOptions base;
        base.emission_samples = 0;
        base.spp = spp;
        base.gather_rays = gather;
        base.direct_samples = direct;
        render::GatherOptions ro = base;
        ro.gather_rays = ref_gather;
        ro.filter.filter = render::Filter::none;
        const auto ref = render::final_gather(scene, caster, ref_field, camera, ro, run).image;
        std::printf("filter,params,mse,seconds_filter\n");
        auto sweeps = [&](const char* name) { return only.empty() || only == name; };
        auto trial = [&](const render::GatherOptions& o, const std::string& params) {
            const auto r = render::final_gather(scene, caster, ref_field, camera, o, run);
            std::printf("%s,%s,%.6g,%.4f\n", render::filter_name(o.filter.filter), params.c_str(), render::mse(r.image, ref),
                        r.seconds_filter);
            std::fflush(stdout);
        };
        render::GatherOptions o = base;
        o.filter.filter = render::Filter::none;
        trial(o, "-");
        if (sweeps("guided"))
        for (int radius : {2, 4, 8, 16, 24, 32})
            for (double en : {0.001, 0.003, 0.01, 0.03, 0.1})
                for (double ed : {0.0001, 0.0003, 0.001, 0.003, 0.01, 0.03}) {
                    o = base;
                    o.filter.filter = render::Filter::guided;
                    o.filter.radius = radius;
                    o.filter.eps_normal = en;
                    o.filter.eps_depth = ed;
                    trial(o, "r=" + std::to_string(radius) + " en=" + std::to_string(en) + " ed=" + std::to_string(ed));
                }
        if (sweeps("bilateral"))
        for (double ss : {1.0, 2.0, 4.0, 8.0})
            for (double sn : {0.05, 0.1, 0.3})
                for (double sd : {0.005, 0.01, 0.02, 0.05}) {
                    o = base;
                    o.filter.filter = render::Filter::bilateral;
                    o.filter.radius = static_cast<int>(2 * ss + 0.5);
                    o.filter.sigma_spatial = ss;
                    o.filter.sigma_normal = sn;
                    o.filter.sigma_depth = sd;
                    trial(o, "s=" + std::to_string(ss) + " sn=" + std::to_string(sn) + " sd=" + std::to_string(sd));
                }
        if (sweeps("atrous"))
        for (int it : {3, 4, 5, 6})
            for (double sc : {0.05, 0.1, 0.3, 1.0})
                for (double sd : {0.01, 0.03, 0.1}) {
                    o = base;
                    o.filter.filter = render::Filter::atrous;
                    o.filter.atrous_iterations = it;
                    o.filter.sigma_colour = sc;
                    o.filter.sigma_normal = 0.3;
                    o.filter.sigma_depth = sd;
                    trial(o, "it=" + std::to_string(it) + " sc=" + std::to_string(sc) + " sd=" + std::to_string(sd));
                }
        return 0;
    }

    // Pipeline: run time against error.
    render::GatherOptions ro;
    ro.spp = 1;
    ro.gather_rays = 2048;
    ro.direct_samples = 256;
    ro.filter.filter = render::Filter::none;
    const auto ref = render::final_gather(scene, caster, ref_field, camera, ro, run).image;
    std::printf("iterations,gather_and_direct,filter,seconds_solve,seconds_gather,seconds,mse\n");
    for (long steps : {250L, 1000L, 4000L}) {
        double seconds_solve = 0.0;
        const auto field = solve(scene, steps, seconds_solve);
        for (int n : {4, 16, 64})
            for (auto f : {render::Filter::none, render::Filter::guided}) {
                render::GatherOptions o;
                o.spp = 1;
                o.gather_rays = n;
                o.direct_samples = n;  // direct and indirect sampling refined together
                o.filter.filter = f;
                o.filter.radius = 8;
                const auto t0 = Clock::now();
                const auto r = render::final_gather(scene, caster, field, camera, o, run);
                const double sg = std::chrono::duration<double>(Clock::now() - t0).count();
                std::printf("%ld,%d,%s,%.4f,%.4f,%.4f,%.6g\n", steps, n, render::filter_name(f), seconds_solve, sg,
                            seconds_solve + sg, render::mse(r.image, ref));
                std::fflush(stdout);
            }
    }
    return 0;
}
