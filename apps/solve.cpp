// `raybundle solve`: load -> solve -> render -> write, and the run's record.
#include "cli.h"
#include "progress.h"
#include "stats.h"

#include "render/camera.h"
#include "render/gbuffer.h"
#include "render/image_io.h"
#include "render/metrics.h"
#include "render/patch_io.h"
#include "render/scene_check.h"
#include "render/shade.h"
#include "scenes/ray_caster.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

namespace raybundle::apps {

namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The warnings a scene deserves before it is solved, one line each.
void warn_about(const scenes::Scene& scene, const render::SceneSummary& summary) {
    const auto& overlaps = summary.overlaps;
    if (scene.dropped_degenerate > 0)
        std::cerr << "raybundle: warning: " << scene.name << ": dropped " << scene.dropped_degenerate
                  << " zero-area triangles\n";
    if (overlaps.pairs > 0)
        std::cerr << "raybundle: warning: " << scene.name << ": " << overlaps.pairs
                  << " pairs of coplanar overlapping patches face the same way (e.g. patches " << overlaps.first << " and "
                  << overlaps.second << "): no visibility map can order them; the higher patch index is in front\n";
    for (const auto& line : render::winding_warnings(summary))
        std::cerr << "raybundle: warning: " << scene.name << ": " << line << "\n";
}

struct Row {
    long step;
    double seconds;
    std::optional<double> error;
    double mean;
};

void write_csv(const std::string& path, const std::vector<Row>& rows) {
    render::write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        out << "iteration,seconds,relative_l1_error,mean_radiance\n";
        out.precision(9);
        for (const auto& r : rows) {
            out << r.step << ',' << r.seconds << ',';
            if (r.error) out << *r.error;
            out << ',' << r.mean << '\n';
        }
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

void make_parent(const std::string& path) {
    const auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
}

// --reference: read before any work, so that a wrong size stops the run at once.
std::optional<render::Image> load_reference(const Command& c, const scenes::Scene& scene) {
    if (c.reference.empty()) return std::nullopt;
    render::Image ref;
    try {
        ref = render::read_exr(c.reference);
    } catch (const std::runtime_error& e) {
        throw UsageError(std::string("--reference ") + e.what());
    }
    if (ref.width != scene.camera.width || ref.height != scene.camera.height)
        throw UsageError("--reference " + c.reference + ": " + std::to_string(ref.width) + "x" +
                         std::to_string(ref.height) + " pixels, the image is " + std::to_string(scene.camera.width) +
                         "x" + std::to_string(scene.camera.height));
    return ref;
}

struct Compared {
    double relative_l1, mse;
};
std::optional<Compared> compare(const std::optional<render::Image>& ref, const render::Image& image) {
    if (!ref) return std::nullopt;
    return Compared{render::relative_l1(image, *ref), render::mse(image, *ref)};
}

void record(json& stats, const Command& c, const std::optional<Compared>& against) {
    if (against)
        stats["reference"] = {{"file", c.reference}, {"relative_l1", against->relative_l1}, {"mse", against->mse}};
}

void print_against(const std::optional<Compared>& against) {
    if (against) std::printf(", against the reference: relative L1 %.4g, MSE %.4g", against->relative_l1, against->mse);
}

// `--method pathtrace`: the reference image, no radiance field.
int path_trace(const Command& c, const scenes::Scene& scene, const scenes::RayCaster& caster,
               const sampling::RunOptions& run, ProgressBar& bar, Clock::time_point t_start,
               const std::optional<render::Image>& reference) {
    const render::PinholeCamera camera(scene.camera);
    const render::PathTraceResult traced = render::path_trace(scene, caster, camera, c.path, run);
    bar.clear();
    const auto against = compare(reference, traced.image);
    for (const auto& path : c.images) {
        make_parent(path);
        render::write_image(path, traced.image, c.exposure);
    }
    json stats = {{"scene", scene.name},
                  {"patches", scene.patch_count()},
                  {"method", "pathtrace"},
                  {"seed", c.run.seed},
                  {"threads_requested", c.run.threads},
                  {"image", {{"width", scene.camera.width}, {"height", scene.camera.height}}},
                  {"path_trace", {{"spp", c.path.spp}, {"paths", traced.paths}, {"rays", traced.rays}}},
                  {"seconds_render", traced.seconds},
                  {"seconds_total", since(t_start)},
                  {"decisions",
                   {{"image", "brute-force path tracing: next-event estimation and BRDF sampling with the balance "
                              "heuristic, Russian roulette; unbiased (render/path_tracer.h)"}}}};
    record(stats, c, against);
    if (!c.stats.empty()) {
        make_parent(c.stats);
        write_json(c.stats, stats);
    }
    if (!c.quiet) {
        std::printf("%s: %zu patches, path traced %d paths per pixel in %.2f s", scene.name.c_str(),
                    scene.patch_count(), c.path.spp, traced.seconds);
        print_against(against);
        std::string wrote;
        for (const auto& path : c.images) wrote += (wrote.empty() ? "" : ", ") + path;
        if (!c.stats.empty()) wrote += (wrote.empty() ? "" : ", ") + c.stats;
        if (!wrote.empty()) std::printf("; wrote %s", wrote.c_str());
        std::printf("\n");
    }
    return 0;
}

}  // namespace

int solve(const Command& c) {
    const auto t_start = Clock::now();
    ProgressBar bar(c.quiet);
    const solver::Solver* solving = nullptr;
    std::vector<Row> rows;
    std::optional<double> exact;
    const scenes::Scene* scene_ptr = nullptr;
    sampling::RunOptions run = c.run;
    long burn_in = 0;  // steps the solver leaves out of its average: no rows for them
    run.progress = [&](const sampling::Progress& p) {
        bar(p);
        if (c.csv.empty() || solving == nullptr || std::string(p.phase) != "solve" || p.done <= burn_in) return;
        const auto field = solving->field();
        std::optional<double> err;
        if (exact) err = field.relative_l1_error(*scene_ptr, *exact);
        rows.push_back({p.done, p.seconds, err, field.mean_radiance(*scene_ptr)});
    };

    const scenes::Scene scene = load_scene(c);
    scene_ptr = &scene;
    const scenes::RayCaster caster(scene);
    // The scene's warnings (the camera's view on a grid of at most 128^2 rays).
    const render::SceneSummary summary = render::summarize(scene, caster, run.threads, 128 * 128);
    warn_about(scene, summary);
    const std::optional<render::Image> reference = load_reference(c, scene);
    if (c.solver.method == "pathtrace") return path_trace(c, scene, caster, run, bar, t_start, reference);

    // The first shot (point lights) and the diffuse shot, once, before any direction.
    // The diffuse shot, unless the command line decided: for diffuse scenes with area
    // lights, whose direct light it makes exact up to its quadrature.
    solver::ShotOptions shots = c.shots;
    std::string shot_choice;
    if (c.diffuse_shot >= 0) {
        shots.diffuse_shot = c.diffuse_shot == 1;
        shot_choice = std::string(shots.diffuse_shot ? "--diffuse-shot" : "--no-diffuse-shot") + " given";
    } else {
        shots.diffuse_shot = scene.has_emission() && !scene.has_glossy();
        shot_choice = shots.diffuse_shot ? "on: a diffuse scene with area lights"
                      : scene.has_glossy() ? "off: the scene has glossy materials"
                                           : "off: the scene has no area lights";
    }
    const solver::Transport transport(scene, shots, run);
    auto solver = solver::make_solver(transport, c.solver, run);
    // What the method converges to on a scene with a known answer (walks truncated at D
    // bounces: a known fraction of it on a homogeneous scene).
    if (scene.exact_radiance) {
        exact = scene.exact_radiance;
        if (scene.homogeneous_albedo) *exact *= solver->converged_fraction(*scene.homogeneous_albedo);
    }
    const auto t_solve = Clock::now();
    burn_in = solver->report().details.value("burn_in_steps", 0L);
    solving = solver.get();
    solver->run();
    solving = nullptr;
    const double seconds_solve = since(t_solve);
    const solver::RadianceField field = solver->field();

    const auto t_render = Clock::now();
    const render::PinholeCamera camera(scene.camera);
    render::Image image;
    std::optional<render::GatherResult> gathered;
    if (c.gather_rays > 0) {
        gathered = render::final_gather(scene, caster, field, camera, c.gather, run);
        image = gathered->image;
    } else {
        image = render::shade(scene, field, render::make_gbuffer(scene, caster, camera, run.threads),
                              render::parse_shading(c.shading));
    }
    const double seconds_render = since(t_render);
    bar.clear();
    const auto against = compare(reference, image);

    // The outputs asked for, their directories made when missing.
    for (const auto& path : c.images) {
        make_parent(path);
        render::write_image(path, image, c.exposure);
    }
    if (gathered && !c.aov.empty()) {
        std::filesystem::create_directories(c.aov);
        const std::pair<const char*, const render::Image*> aovs[] = {
            {"direct", &gathered->direct}, {"indirect", &gathered->indirect},
            {"indirect-filtered", &gathered->indirect_filtered}, {"normal", &gathered->normal}, {"depth", &gathered->depth}};
        for (const auto& [name, img] : aovs) render::write_exr(c.aov + "/" + name + ".exr", *img);
    }
    for (const auto* path : {&c.patches_csv, &c.ply, &c.csv, &c.stats})
        if (!path->empty()) make_parent(*path);
    if (!c.patches_csv.empty()) render::write_patch_csv(c.patches_csv, scene, field);
    if (!c.ply.empty()) render::write_patch_ply(c.ply, scene, field, c.exposure);
    if (!c.csv.empty()) write_csv(c.csv, rows);

    const solver::SolverReport report = solver->report();
    const double mean = field.mean_radiance(scene);
    json stats = run_record(scene, c, report, transport, summary.overlaps.pairs);
    stats["seconds_total"] = since(t_start);
    stats["seconds_solve"] = seconds_solve;
    stats["seconds_render"] = seconds_render;
    stats["seconds_per_iteration"] = report.steps > 0 ? seconds_solve / report.steps : 0.0;
    stats["seconds_per_direction"] = report.directions > 0 ? seconds_solve / report.directions : 0.0;
    stats["mean_radiance"] = mean;
    if (gathered) stats["final_gather"] = gather_record(c, *gathered);
    stats["decisions"]["diffuse_shot_choice"] = shot_choice;
    stats["decisions"]["image"] = gathered ? "final gather: direct light per sample, indirect at guide rays, " +
                                                 std::string(render::filter_name(c.gather.filter.filter)) + " filter"
                                           : "the patch radiance (" + c.shading + " shading); --gather N for a final gather";
    std::optional<double> error;
    if (exact) {
        error = field.relative_l1_error(scene, *exact);
        stats["exact_radiance"] = *exact;
        stats["relative_l1_error"] = *error;
    }
    record(stats, c, against);
    if (!c.stats.empty()) write_json(c.stats, stats);

    if (!c.quiet) {
        std::printf("%s: %zu patches, %s %ld steps in %.2f s", scene.name.c_str(), scene.patch_count(),
                    report.method.c_str(), report.steps, seconds_solve);
        if (gathered) std::printf(", final gather %.2f s", seconds_render);
        std::printf(", mean radiance %.6g", mean);
        if (error) std::printf(", relative L1 error %.3g", *error);
        print_against(against);
        std::vector<std::string> written = c.images;
        if (gathered && !c.aov.empty()) written.push_back(c.aov + "/");
        for (const auto* path : {&c.stats, &c.csv, &c.patches_csv, &c.ply})
            if (!path->empty()) written.push_back(*path);
        std::string wrote;
        for (const auto& path : written) wrote += (wrote.empty() ? "" : ", ") + path;
        if (!wrote.empty()) std::printf("; wrote %s", wrote.c_str());
        std::printf("\n");
    }
    return 0;
}

}  // namespace raybundle::apps
