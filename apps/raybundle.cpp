// raybundle: the command line. Thin: parse into an options struct, check it, then
// load -> solve -> render -> write, inside one try/catch.
#include "progress.h"
#include "stats.h"

#include "render/camera.h"
#include "render/final_gather.h"
#include "render/gbuffer.h"
#include "render/image_io.h"
#include "render/patch_io.h"
#include "render/shade.h"
#include "scenes/builtin.h"
#include "scenes/diagnostics.h"
#include "scenes/loader.h"
#include "scenes/ray_caster.h"
#include "scenes/scene_error.h"
#include "solver/global_walks.h"
#include "solver/linear_basis.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"
#include "visibility/parallel.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <sys/stat.h>

namespace rb = raybundle;
using json = nlohmann::json;

namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitFailure = 1;

struct SolveOptions {
    std::string scene_file;
    std::string builtin;
    std::optional<double> patch_size;
    std::string exr = "out.exr";
    std::string png, stats, csv, patches_csv, ply;
    long iterations = 1000;
    int resolution = 0;
    std::string visibility;  // empty: the default backend (the linear basis: its own painter)
    std::uint64_t seed = 1;
    int threads = 1;
    std::string shading = "smooth";
    double exposure = 0.0;
    long csv_every = 0;
    std::string method = "iteration";
    bool bidirectional = true;
    bool bidirectional_given = false;
    int depth = 5;
    bool depth_given = false;
    bool unbiased = false;
    std::string sampler = "random";
    std::string basis = "constant";
    bool diffuse_shot = false;
    // Final gather (0 gather rays: the patch image).
    int gather = 0;
    int direct_samples = 16;
    int spp = 1;
    std::string filter = "guided";
    int filter_radius = 8;
    double eps_normal = 0.01, eps_depth = 1e-4;
    std::string aov;
    std::vector<std::string> gather_flags_given;  // final-gather flags on the command line
};

// An error in what the user gave us: reported as one line, exit code 2.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

void check_output_dir(const std::string& path, const char* flag) {
    if (path.empty()) return;
    const auto slash = path.find_last_of('/');
    const std::string dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
    struct stat st {};
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
        throw UsageError(std::string(flag) + " " + path + ": directory '" + dir + "' does not exist");
    if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
        throw UsageError(std::string(flag) + " " + path + ": is a directory, not a file");
}

// A CLI11 validator: a finite number (NaN and infinities pass CLI11's ranges).
const CLI::Validator kFinite(
    [](std::string& text) {
        try {
            std::size_t used = 0;
            const double x = std::stod(text, &used);
            if (used == text.size() && std::isfinite(x)) return std::string();
        } catch (const std::exception&) {
        }
        return "'" + text + "' is not a finite number";
    },
    "FINITE");

// A CLI11 validator: a finite number > 0.
const CLI::Validator kPositiveFinite(
    [](std::string& text) {
        std::string copy = text;
        std::string bad = kFinite(copy);
        if (!bad.empty()) return bad;
        return std::stod(text) > 0.0 ? std::string() : "'" + text + "' is not > 0";
    },
    "POSITIVE");

// A CLI11 validator: a non-negative integer written in decimal digits (an unsigned
// option would otherwise take -1 as 2^64 - 1).
const CLI::Validator kDigits(
    [](std::string& text) {
        if (!text.empty() && text.find_first_not_of("0123456789") == std::string::npos) return std::string();
        return "'" + text + "' is not a non-negative integer";
    },
    "UINT");

int run_solve(const SolveOptions& o) {
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();

    if (o.scene_file.empty() == o.builtin.empty())
        throw UsageError("solve: give exactly one of SCENE.json or --builtin NAME");
    if (o.method == "iteration") {
        if (o.sampler != "random")
            throw UsageError("--sampler " + o.sampler + ": stochastic iteration needs independent consecutive "
                             "directions (004 section 4.4); use a QMC sampler with --method walk, combined or "
                             "bidirectional");
        if (o.unbiased) throw UsageError("--unbiased applies to the walk methods (stochastic iteration is unbiased)");
        if (o.depth_given) throw UsageError("--depth applies to the walk methods, not to --method iteration");
    } else if (o.bidirectional_given) {
        throw UsageError("--bidirectional/--no-bidirectional apply to --method iteration; for walks use "
                         "--method bidirectional");
    }
    if (o.basis == "linear") {
        if (o.method != "iteration")
            throw UsageError("--basis linear works with --method iteration (got --method " + o.method + ")");
        if (!o.visibility.empty() && o.visibility != "painter")
            throw UsageError("--basis linear uses the centre-sorted painter's radiance map (the basis lives in its "
                             "rasteriser); got --visibility " + o.visibility);
    }
    if (o.sampler == "sobol" && o.depth > rb::sampling::WalkSampler::kMaxSobolDepth)
        throw UsageError("--depth " + std::to_string(o.depth) + ": the sobol sampler supports depths up to " +
                         std::to_string(rb::sampling::WalkSampler::kMaxSobolDepth));
    const std::pair<std::string, const char*> outputs[] = {{o.exr, "-o"},          {o.png, "--png"},
                                                           {o.stats, "--stats"},   {o.csv, "--csv"},
                                                           {o.patches_csv, "--patches"}, {o.ply, "--ply"}};
    for (const auto& [path, flag] : outputs) check_output_dir(path, flag);
    for (std::size_t a = 0; a < std::size(outputs); ++a)
        for (std::size_t b = a + 1; b < std::size(outputs); ++b)
            if (!outputs[a].first.empty() && outputs[a].first == outputs[b].first)
                throw UsageError(std::string(outputs[a].second) + " and " + outputs[b].second + " name the same file " +
                                 outputs[a].first);
    if (!o.aov.empty()) {
        struct stat st {};
        if (::stat(o.aov.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
            throw UsageError("--aov " + o.aov + ": not a directory");
    }
    if (o.gather == 0 && !o.gather_flags_given.empty())
        throw UsageError(o.gather_flags_given.front() + " needs the final gather (--gather N)");
    if (o.unbiased && o.sampler != "random")
        throw UsageError("--unbiased needs --sampler random: the correction carries one walk's light into the next, "
                         "and consecutive " + o.sampler + " points are correlated");

    rb::scenes::Scene scene = o.builtin.empty() ? rb::scenes::load_scene(o.scene_file, o.patch_size)
                                                : rb::scenes::make_builtin(o.builtin, o.patch_size);
    if (scene.dropped_degenerate > 0)
        std::cerr << "raybundle: warning: " << scene.name << ": dropped " << scene.dropped_degenerate
                  << " zero-area triangles\n";
    const auto overlaps = rb::scenes::coplanar_overlaps(scene);
    if (overlaps.pairs > 0)
        std::cerr << "raybundle: warning: " << scene.name << ": " << overlaps.pairs
                  << " pairs of coplanar overlapping patches face the same way (e.g. patches " << overlaps.first
                  << " and " << overlaps.second << "): no visibility map can order them; the higher patch index is in front\n";
    const auto shading = rb::render::parse_shading(o.shading);

    rb::visibility::BackendOptions bopt;
    bopt.resolution = o.resolution;
    bopt.sky = scene.sky.has_value();  // no sky: no sky entries in the maps
    // The linear basis brings its own (Gouraud) painter; the others use the backend.
    // One backend per thread: the visibility of several directions is computed side by
    // side, the light moves along them in order (results identical for any --threads).
    std::unique_ptr<rb::visibility::BackendSet> backends;
    if (o.basis == "constant")
        backends = std::make_unique<rb::visibility::BackendSet>(
            o.visibility.empty() ? rb::visibility::kDefaultBackend : o.visibility, scene, bopt, o.threads);
    rb::visibility::Backend* backend = backends ? &backends->front() : nullptr;

    // The first shot (point lights) happens here, once, before any direction.
    const rb::solver::Transport transport(scene, rb::solver::ShotOptions{o.diffuse_shot});

    std::optional<rb::solver::StochasticIteration> iteration;
    std::optional<rb::solver::GlobalWalks> walks;
    std::optional<rb::solver::LinearIteration> linear;
    rb::solver::IterationOptions sopt;
    sopt.iterations = o.iterations;
    sopt.seed = o.seed;
    sopt.progress_every = o.csv_every;
    sopt.bidirectional = o.bidirectional;
    if (o.basis == "linear") {
        linear.emplace(transport, bopt, sopt);
    } else if (o.method == "iteration") {
        iteration.emplace(transport, *backends, sopt);
    } else {
        rb::solver::WalkOptions wopt;
        wopt.method = o.method == "walk"       ? rb::solver::WalkMethod::walk
                      : o.method == "combined" ? rb::solver::WalkMethod::combined
                                               : rb::solver::WalkMethod::bidirectional;
        wopt.depth = o.depth;
        wopt.walks = o.iterations;
        wopt.unbiased = o.unbiased;
        wopt.sampler = rb::sampling::parse_sampler(o.sampler);
        wopt.seed = o.seed;
        wopt.progress_every = o.csv_every;
        walks.emplace(transport, *backends, wopt);
    }
    auto current_field = [&]() {
        return linear ? linear->field() : iteration ? iteration->field() : walks->field();
    };
    // What the method converges to on a scene with a known answer: walks truncated at
    // D bounces converge to a known fraction of it on a homogeneous scene.
    std::optional<double> exact = scene.exact_radiance;
    if (exact && walks && !o.unbiased) {
        if (scene.homogeneous_albedo)
            // The diffuse shot adds the first bounce exactly: D + 1 bounces.
            *exact *= rb::solver::GlobalWalks::truncation_factor(*scene.homogeneous_albedo,
                                                                 o.depth + (o.diffuse_shot ? 1 : 0), false);
        else
            exact.reset();
    }

    // Convergence rows every k steps; the bar on a terminal.
    struct Row {
        long iteration;
        double seconds;
        std::optional<double> error;
        double mean;
    };
    std::vector<Row> rows;
    rb::apps::ProgressBar bar("solve");
    const auto t_solve = Clock::now();
    const auto on_progress = [&](const rb::solver::Progress& p) {
        bar.update(p.iteration, p.total, p.seconds);
        if (o.csv.empty()) return;
        const auto field = current_field();
        std::optional<double> err;
        if (exact) err = field.relative_l1_error(scene, *exact);
        rows.push_back({p.iteration, p.seconds, err, field.mean_radiance(scene)});
    };
    if (linear)
        linear->run(on_progress);
    else if (iteration)
        iteration->run(on_progress);
    else
        walks->run(on_progress);
    bar.finish();
    const double seconds_solve = std::chrono::duration<double>(Clock::now() - t_solve).count();
    const auto field = current_field();

    const auto t_render = Clock::now();
    rb::scenes::RayCaster caster(scene);
    const rb::render::PinholeCamera camera(scene.camera);
    rb::render::Image image;
    std::optional<rb::render::GatherResult> gathered;
    rb::render::GatherOptions gopt;
    if (o.gather > 0) {
        gopt.gather_rays = o.gather;
        gopt.direct_samples = o.direct_samples;
        gopt.spp = o.spp;
        gopt.filter = rb::render::parse_filter(o.filter);
        gopt.radius = o.filter_radius;
        gopt.eps_normal = o.eps_normal;
        gopt.eps_depth = o.eps_depth;
        gopt.seed = o.seed;
        gopt.threads = o.threads;
        gathered = rb::render::final_gather(scene, caster, field, camera, gopt);
        image = gathered->image;
    } else {
        const auto gbuffer = rb::render::make_gbuffer(scene, caster, camera);
        image = rb::render::shade(scene, field, gbuffer, shading);
    }
    const double seconds_render = std::chrono::duration<double>(Clock::now() - t_render).count();

    if (!o.exr.empty()) rb::render::write_exr(o.exr, image);
    if (gathered && !o.aov.empty()) {
        rb::render::write_exr(o.aov + "/direct.exr", gathered->direct);
        rb::render::write_exr(o.aov + "/indirect.exr", gathered->indirect);
        rb::render::write_exr(o.aov + "/indirect-filtered.exr", gathered->indirect_filtered);
        rb::render::write_exr(o.aov + "/normal.exr", gathered->normal);
        rb::render::write_exr(o.aov + "/depth.exr", gathered->depth);
    }
    if (!o.png.empty()) rb::render::write_png(o.png, image, o.exposure);
    if (!o.patches_csv.empty()) rb::render::write_patch_csv(o.patches_csv, scene, field);
    if (!o.ply.empty()) rb::render::write_patch_ply(o.ply, scene, field, o.exposure);
    if (!o.csv.empty()) {
        rb::render::write_atomically(o.csv, [&](const std::string& tmp) {
            std::ofstream out(tmp);
            out << "iteration,seconds,relative_l1_error,mean_radiance\n";
            out.precision(9);
            for (const auto& r : rows) {
                out << r.iteration << ',' << r.seconds << ',';
                if (r.error) out << *r.error;
                out << ',' << r.mean << '\n';
            }
            out.close();
            if (!out) throw std::runtime_error(o.csv + ": write failed");
        });
    }

    // The figures both solvers report.
    struct {
        long steps, directions;
        double seconds_visibility, seconds_transport;
        std::size_t entries_total;
        std::string shading;
    } st;
    if (linear || iteration) {
        const auto& s = linear ? linear->stats() : iteration->stats();
        st = {s.iterations, s.directions, s.seconds_visibility, s.seconds_transport, s.entries_total, s.shading};
    } else {
        const auto& s = walks->stats();
        st = {s.walks, s.directions, s.seconds_visibility, s.seconds_transport, s.entries_total, s.shading};
    }
    const auto& shot = transport.shot_stats();
    const double mean = field.mean_radiance(scene);
    std::string sky_decision = "none: the scene has no sky (no sky entries in the maps)";
    if (scene.sky)
        sky_decision = std::string(scene.sky->model == rb::scenes::Sky::Model::constant ? "constant" : "CIE overcast") +
                       " sky: map pixels that no patch covers upstream carry the sky radiance";
    json stats = {
        {"scene", scene.name},
        {"patches", scene.patch_count()},
        {"dropped_degenerate_triangles", scene.dropped_degenerate},
        {"coplanar_overlaps", overlaps.pairs},
        {"method", o.method},
        {"iterations", st.steps},
        {"directions", st.directions},
        {"visibility", backend ? backend->name() : "painter"},
        {"visibility_details", backend ? backend->details() : "centre-sorted Gouraud radiance map (--basis linear)"},
        {"visibility_exact", backend ? rb::visibility::backend_info(backend->name()).exact : false},
        {"resolution", backend ? backend->resolution() : linear->resolution()},
        {"basis", o.basis},
        {"seed", o.seed},
        {"threads", backends ? backends->threads() : 1},
        {"threads_requested", o.threads},
        {"image", {{"width", camera.width()}, {"height", camera.height()}, {"shading", o.shading}}},
        {"seconds_total", std::chrono::duration<double>(Clock::now() - t_start).count()},
        {"seconds_solve", seconds_solve},
        {"seconds_per_iteration", st.steps > 0 ? seconds_solve / st.steps : 0.0},
        {"seconds_per_direction", st.directions > 0 ? seconds_solve / st.directions : 0.0},
        {"seconds_first_shot", shot.seconds},
        {"seconds_diffuse_shot", shot.diffuse_seconds},
        {"seconds_visibility", st.seconds_visibility},
        {"seconds_transport", st.seconds_transport},
        {"seconds_render", seconds_render},
        {"geometry_entries_per_direction",
         st.directions > 0 ? static_cast<double>(st.entries_total) / st.directions : 0.0},
        {"mean_radiance", mean},
        {"decisions",
         {{"shading", st.shading},
          {"first_shot", shot.lights == 0 ? std::string("skipped: no point lights")
                                           : std::to_string(shot.lights) + " point light(s), " +
                                                 std::to_string(shot.shadow_rays) +
                                                 " shadow rays, then they leave the iteration"},
          {"sky", sky_decision},
          {"diffuse_shot", o.diffuse_shot ? std::to_string(shot.emitters) + " emissive patches, " +
                                                std::to_string(shot.diffuse_rays) +
                                                " shadow rays: direct light computed once, the emission moves no more"
                                          : std::string("off (--diffuse-shot computes the area lights' direct light once)")},
          {"threads", "visibility: " + std::to_string(backends ? backends->threads() : 1) +
                          (backends && backends->threads() < o.threads ? " (this backend runs one at a time)" : "") +
                          " (one backend each; the light moves in order, so any count gives the same result)" +
                          (o.gather > 0 ? "; final gather and filters: " + std::to_string(o.threads) : "")}}},
    };
    if (linear) {
        stats["nodes"] = linear->nodes();
        stats["memory_per_patch_bytes"] =
            (3 * sizeof(rb::scenes::Rgb) * linear->nodes() + 6 * sizeof(rb::scenes::Rgb) * scene.patch_count()) /
            scene.patch_count();
    }
    if (linear || iteration) {
        stats["decisions"]["directions_per_step"] = o.bidirectional
                                                        ? "w and -w from one geometry matrix (weight 1/2 each)"
                                                        : "w only (--no-bidirectional)";
        if (!linear) stats["memory_per_patch_bytes"] = 4 * sizeof(rb::scenes::Rgb);
    } else {
        const auto& ws = walks->stats();
        stats["walks"] = ws.walks;
        stats["depth"] = o.depth;
        stats["sampler"] = o.sampler;
        stats["unbiased"] = o.unbiased;
        stats["memory_per_patch_bytes"] = ws.bytes_per_patch;
        stats["decisions"]["storage"] = ws.storage;
    }
    if (gathered) {
        stats["final_gather"] = {{"gather_rays", o.gather},
                                 {"direct_samples", o.direct_samples},
                                 {"spp", o.spp},
                                 {"filter", o.filter},
                                 {"filter_radius", o.filter_radius},
                                 {"eps_normal", o.eps_normal},
                                 {"eps_depth", o.eps_depth},
                                 {"threads", o.threads},
                                 {"camera_rays", gathered->camera_rays},
                                 {"shadow_rays", gathered->shadow_rays},
                                 {"gather_rays_total", gathered->gather_rays},
                                 {"seconds_guides", gathered->seconds_guides},
                                 {"seconds_filter", gathered->seconds_filter},
                                 {"seconds_samples", gathered->seconds_samples}};
        stats["decisions"]["image"] = "final gather: direct light per sample, indirect at guide rays, " + o.filter +
                                      " filter";
    } else {
        stats["decisions"]["image"] = "the patch radiance (" + o.shading + " shading); --gather N for a final gather";
    }
    if (exact) {
        stats["exact_radiance"] = *exact;
        stats["relative_l1_error"] = field.relative_l1_error(scene, *exact);
    }
    if (!o.stats.empty()) rb::apps::write_json(o.stats, stats);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"raybundle: global ray-bundle radiance solver"};
    app.require_subcommand(1);
    SolveOptions o;

    auto* solve = app.add_subcommand("solve", "solve a scene's radiance by global ray-bundle stochastic iteration");
    solve->add_option("scene", o.scene_file, "scene file (JSON, see docs/scene-format.md)");
    solve->add_option("--builtin", o.builtin, "a built-in scene instead of a file (see `raybundle scenes`)");
    solve->add_option("--patch-size", o.patch_size, "refine until no patch edge is longer (scene units)");
    solve->add_option("-o,--output", o.exr, "linear EXR image")->capture_default_str();
    solve->add_option("--png", o.png, "sRGB PNG image (tone map: see --exposure)");
    solve->add_option("--exposure", o.exposure, "PNG exposure in stops: 2^exposure * L, clamped, sRGB")
        ->check(kFinite)
        ->capture_default_str();
    solve->add_option("--shading", o.shading, "image from the patch radiance: smooth | flat")->capture_default_str();
    solve->add_option("--iterations", o.iterations, "stochastic iteration steps, or walks for the walk methods")
        ->capture_default_str()
        ->check(CLI::Range(1L, 1000000000L));
    solve->add_option("--resolution", o.resolution, "visibility map pixels per side (default: from the scene)")
        ->check(CLI::Range(1, 16384));
    solve->add_option("--visibility", o.visibility,
                      std::string("visibility backend (see `raybundle backends`; default: ") +
                          rb::visibility::kDefaultBackend + ")");
    solve->add_option("--seed", o.seed, "random seed; the same seed gives bit-identical output")
        ->check(kDigits)
        ->capture_default_str();
    solve->add_option("--threads", o.threads, "threads: one visibility backend each, and the final gather (same result for any count)")
        ->capture_default_str()
        ->check(CLI::Range(1, 1024));
    solve->add_option("--method", o.method,
                      "iteration (stochastic iteration) | walk | combined | bidirectional (global walks of --depth)")
        ->capture_default_str()
        ->check(CLI::IsMember({"iteration", "walk", "combined", "bidirectional"}));
    solve->add_option("--depth", o.depth, "directions (bounces) per global walk")
        ->capture_default_str()
        ->check(CLI::Range(1, 32))
        ->each([&](const std::string&) { o.depth_given = true; });
    solve->add_flag("--unbiased", o.unbiased,
                    "walks: correct the next walk's emission with this walk's last bounce (004 4.3)");
    solve->add_option("--basis", o.basis,
                      "constant (per patch) | linear (per vertex, Gouraud; iteration with the painter's map)")
        ->capture_default_str()
        ->check(CLI::IsMember({"constant", "linear"}));
    solve->add_flag("--diffuse-shot", o.diffuse_shot,
                    "compute the area lights' direct light once with shadow rays (004 9.1; diffuse scenes)");
    solve->add_option("--gather", o.gather,
                      "final gather (003) with N cosine-weighted rays per pixel for the indirect light (0: off)")
        ->capture_default_str()
        ->check(CLI::Range(0, 1 << 20));
    solve->add_option("--direct-samples", o.direct_samples, "final gather: light-source samples per camera sample")
        ->capture_default_str()
        ->check(CLI::Range(0, 1 << 16));
    solve->add_option("--spp", o.spp, "final gather: camera samples per pixel (the first is the guide ray)")
        ->capture_default_str()
        ->check(CLI::Range(1, 4096));
    solve->add_option("--filter", o.filter, "final gather: filter for the indirect light: guided | bilateral | atrous | none")
        ->capture_default_str()
        ->check(CLI::IsMember({"guided", "bilateral", "atrous", "none"}));
    solve->add_option("--filter-radius", o.filter_radius,
                      "final gather: window radius in pixels of the guided and bilateral filters (A-Trous: 5 passes)")
        ->capture_default_str()
        ->check(CLI::Range(1, 1024));
    solve->add_option("--eps-normal", o.eps_normal, "guided filter: regularisation of the normal channels")
        ->capture_default_str()
        ->check(kPositiveFinite);
    solve->add_option("--eps-depth", o.eps_depth, "guided filter: regularisation of the depth channel")
        ->capture_default_str()
        ->check(kPositiveFinite);
    solve->add_option("--aov", o.aov,
                      "final gather: also write direct, indirect, indirect-filtered, normal, depth EXRs into DIR");
    solve->add_option("--sampler", o.sampler, "walk directions: random | halton | sobol (randomised QMC)")
        ->capture_default_str()
        ->check(CLI::IsMember({"random", "halton", "sobol"}));
    solve->add_flag("--bidirectional,!--no-bidirectional", o.bidirectional,
                    "iteration: use every geometry matrix for w and -w (default; about 4x smaller error per step)")
        ->each([&](const std::string&) { o.bidirectional_given = true; });
    solve->add_option("--stats", o.stats, "run statistics (JSON)");
    solve->add_option("--csv", o.csv, "convergence table: iteration,seconds,relative_l1_error,mean_radiance");
    solve->add_option("--csv-every", o.csv_every, "convergence row every k iterations (default: 100 rows)")
        ->check(CLI::Range(1L, 1000000000L));
    solve->add_option("--patches", o.patches_csv, "per-patch CSV: id,cx,cy,cz,nx,ny,nz,area,r,g,b");
    solve->add_option("--ply", o.ply, "per-patch PLY with radiance colours (MeshLab)");

    auto* scenes_cmd = app.add_subcommand("scenes", "list the built-in scenes");
    auto* backends_cmd = app.add_subcommand("backends", "list the visibility backends");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitBadInput;
    }
    for (const char* flag : {"--spp", "--aov", "--direct-samples", "--filter", "--filter-radius", "--eps-normal",
                             "--eps-depth"})
        if (solve->count(flag) > 0) o.gather_flags_given.emplace_back(flag);

    try {
        if (scenes_cmd->parsed()) {
            for (const auto& s : rb::scenes::builtin_scenes())
                std::printf("%-16s %s (default patch size %g)\n", s.name.c_str(), s.description.c_str(),
                            s.default_patch_size);
            return 0;
        }
        if (backends_cmd->parsed()) {
            for (const auto& b : rb::visibility::backend_infos())
                std::printf("%-15s %-11s %s\n", b.name.c_str(), b.exact ? "exact" : "approximate", b.summary.c_str());
            return 0;
        }
        return run_solve(o);
    } catch (const rb::scenes::SceneError& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitBadInput;
    } catch (const UsageError& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitBadInput;
    } catch (const std::invalid_argument& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitBadInput;
    } catch (const std::exception& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitFailure;
    }
}
