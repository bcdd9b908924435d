// The options of `raybundle solve` and `raybundle check`, and the checks only the
// command line can make.
#include "cli.h"

#include "render/image_io.h"
#include "render/patch_io.h"
#include "scenes/errors.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <type_traits>

namespace raybundle::apps {

namespace {

// CLI11 validators: a finite number (NaN and infinities pass CLI11's ranges), a
// positive one, and digits only (an unsigned option would take -1 as 2^64 - 1).
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
const CLI::Validator kPositive(
    [](std::string& text) {
        std::string copy = text;
        const std::string bad = kFinite(copy);
        return !bad.empty() ? bad : std::stod(text) > 0.0 ? std::string() : "'" + text + "' is not > 0";
    },
    "POSITIVE");
const CLI::Validator kDigits(
    [](std::string& text) {
        if (!text.empty() && text.size() <= 20 && text.find_first_not_of("0123456789") == std::string::npos &&
            (text.size() < 20 || text <= "18446744073709551615"))
            return std::string();
        return "'" + text + "' is not an integer in 0..2^64-1";
    },
    "UINT64");

// --patch-size: a length, or the scene file's words for its sizes.
const CLI::Validator kPatchSize(
    [](std::string& text) {
        if (text == "auto" || text == "none") return std::string();
        std::string copy = text;
        const std::string bad = kPositive(copy);
        return bad.empty() ? bad : bad + " (a length > 0, auto or none)";
    },
    "L|auto|none");

// An integer option's value: digits with an optional sign (CLI11's range check would
// say that 100.5 is not in range 1 to 16384).
const CLI::Validator kInteger(
    [](std::string& text) {
        const std::size_t from = !text.empty() && (text[0] == '-' || text[0] == '+') ? 1 : 0;
        if (text.size() > from && text.find_first_not_of("0123456789", from) == std::string::npos) return std::string();
        return "'" + text + "' is not an integer";
    },
    "INT");

// --checkpoint-every: a step count (digits, at least 1) or seconds (a positive number
// and 's').
const CLI::Validator kEvery(
    [](std::string& text) {
        const std::string bad = "'" + text + "' is neither steps (N >= 1) nor seconds (e.g. 30s)";
        if (text.empty()) return bad;
        if (text.back() == 's') {
            std::string number = text.substr(0, text.size() - 1);
            return kPositive(number).empty() ? std::string() : bad;
        }
        if (text.size() > 18 || text.find_first_not_of("0123456789") != std::string::npos || std::stol(text) < 1) return bad;
        return std::string();
    },
    "N|Ss");

// A flag's choices: an enum's names array (one list for the library's parsing, its
// messages and the command line).
template <std::size_t N>
CLI::IsMember choices(const std::array<const char*, N>& names) {
    return CLI::IsMember(std::vector<std::string>(names.begin(), names.end()));
}

}  // namespace

// The one list of the command line's options is the rows that add_scene_options and
// add_solve_options make: each row adds its flag (bound to the library's field, so the
// default shown is the library's) and says which library option it sets (the name an
// OptionError gives, for flag_of) and whether it is part of the run's identity (what a
// checkpoint must match to be resumed: everything that decides the result; not the
// outputs, the thread count, the chatter or the checkpoint flags themselves).
void Flags::row(const char* option, Identity identity, CLI::Option* flag, const char* shown) {
    rows_.push_back({option, identity == Identity::yes, flag, shown ? shown : flag->get_name()});
    // An integer is decimal: "02000" is 2000 (CLI11 would read it as octal, 1024).
    if (const std::string type = flag->get_type_name(); type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0)
        flag->transform([](std::string v) {
            const std::size_t digits = v.find_first_not_of("+-");
            if (digits == std::string::npos || v.find_first_not_of("0123456789", digits) != std::string::npos) return v;
            const std::size_t first = std::min(v.find_first_not_of('0', digits), v.size() - 1);
            return v.substr(0, digits) + v.substr(first);
        }, "", "decimal");
}

std::string Flags::flag_of(const std::string& option) const {
    for (const Row& r : rows_)
        if (option == r.option) return r.shown;
    return option;
}

nlohmann::json Flags::identity() const {
    nlohmann::json options = nlohmann::json::object();
    for (const Row& r : rows_)
        if (r.identity && r.flag->count() > 0) options[r.flag->get_name()] = r.flag->results();
    return options;
}

void add_scene_options(CLI::App& cmd, Command& c) {
    Flags& f = c.flags;
    f.row("", Identity::no, cmd.add_option("scene", c.scene_file, "scene file (JSON, see docs/scene-format.md), an OBJ model with its MTL, or a glTF 2.0 file (.gltf, .glb)"));
    f.row("", Identity::yes, cmd.add_option("--builtin", c.builtin, "a built-in scene instead of a file (see `raybundle scenes`)"));
    f.row("", Identity::yes, cmd.add_option("-D", c.defines, "set a scene value: -D key=value (e.g. -D patch_size=20 -D camera.width=800)")
                                          ->allow_extra_args(false));
    auto shortcut = [&](const char* flag, const char* key, const char* help, const CLI::Validator& check,
                        bool integer = false) {
        CLI::Option* option =
            cmd.add_option_function<std::string>(
                flag, [&c, key, flag](const std::string& v) { c.overrides.push_back({key, v, std::string(flag) + " " + v}); },
                help);
        if (integer) option->check(kInteger);
        f.row(key, Identity::yes, option->check(check));
    };
    shortcut("--patch-size", "patch_size",
             "refine until no patch edge is longer; auto: 1/25 of the scene's size; none: as modelled (-D patch_size=L)",
             kPatchSize);
    shortcut("--width", "camera.width", "image width in pixels (-D camera.width=W)", CLI::Range(1, 16384), true);
    shortcut("--height", "camera.height", "image height in pixels (-D camera.height=H)", CLI::Range(1, 16384), true);
    shortcut("--fov", "camera.fov_y", "vertical field of view in degrees (-D camera.fov_y=F)", kPositive);
    f.row("threads", Identity::no,
          cmd.add_option("--threads", c.config.run.threads, "threads (default: all cores; the same result for any count)")
              ->check(kInteger)
              ->check(CLI::Range(1, 1024)));
}

void add_solve_options(CLI::App& cmd, Command& c) {
    add_scene_options(cmd, c);
    Flags& f = c.flags;
    solver::SolverOptions& s = c.config.solver;
    render::GatherOptions& g = c.config.gather;
    constexpr auto yes = Identity::yes, no = Identity::no;
    // An option bound to a field, its default (the library's) shown.
    auto value = [&cmd](const char* names, auto& field, const std::string& help) {
        CLI::Option* option = cmd.add_option(names, field, help)->capture_default_str();
        using T = std::decay_t<decltype(field)>;
        if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) option->check(kInteger);
        return option;
    };
    // An option whose value a library parser turns into the field (an enum's names).
    auto parsed = [&cmd](const char* names, auto set, const std::string& help) {
        return cmd.add_option_function<std::string>(names, set, help);
    };
    // A pair of flags that set an optional<bool> (unset: the library decides).
    auto on_off = [&](const char* option, const char* on, const char* off, std::optional<bool>& v, const std::string& help) {
        f.row(option, yes, cmd.add_flag_callback(on, [&v] { v = true; }, help));
        f.row(option, yes, cmd.add_flag_callback(off, [&v] { v = false; }, "not " + std::string(on)));
    };
    f.row("output", no, cmd.add_option("-o,--output", c.images, "image file: .exr (linear), .png (sRGB) or .pfm; or .glb: the patches with their radiance as vertex colours; repeat for several")
                                ->allow_extra_args(false),  // one file a use: "-o x.png scene.json" names the scene
          "-o");
    f.row("", no, cmd.add_option("--exposure", c.exposure, "PNG exposure in stops: 2^exposure * L, clamped, sRGB")->check(kFinite));
    f.row("method", yes, value("--method", s.method, "iteration | walk | combined | bidirectional; or pathtrace: no solve, a "
                                                      "reference image by brute-force path tracing (--spp paths per pixel, default 256)"));
    f.row("steps", yes, value("--iterations", s.steps, "stochastic iteration steps, or walks for the walk methods")
                            ->check(CLI::Range(1L, 1000000000L)));
    f.row("depth", yes, value("--depth", s.depth, "walks: directions (bounces) per walk"));
    f.row("unbiased", yes, cmd.add_flag("--unbiased", s.unbiased, "walks: correct the next walk's emission with this walk's last bounce"));
    f.row("sampler", yes, parsed("--sampler", [&s](const std::string& v) { s.sampler = sampling::parse_sampler(v); },
                                 "walk directions: random | halton | sobol, or importance-sampled for the image: vegas | metropolis")
                              ->check(choices(sampling::kSamplerNames)));
    f.row("mutation_size", yes, value("--mutation-size", s.mutation_size, "metropolis: the perturbation's extent in the walk's unit cube")
                                    ->check(CLI::Range(1e-6, 1.0)));
    f.row("large_step", yes, value("--large-step", s.large_step, "metropolis: the probability of an independent new walk, from "
                                                                 "the density learnt from the chains")
                                 ->check(CLI::Range(0.0, 1.0)));
    f.row("seed_walks", yes, value("--seed-walks", s.seed_walks, "metropolis: the first N walks of each chain are uniform seeds, "
                                                                 "whose importance picks the starting walks (0: 30 % of the walks)")
                                 ->check(CLI::Range(0L, 1000000000L)));
    f.row("both_ways", yes, cmd.add_flag("--both-ways,!--one-way", s.both_ways,
                                         "iteration: every geometry matrix serves w and -w (default), or w only"),
          "--one-way");
    on_off("ambient", "--ambient", "--no-ambient", s.ambient,
           "iteration: the ambient control variate and start (default: on where an albedo passes sqrt(3)/2, "
           "docs/stability.md)");
    on_off("frame", "--frame", "--no-frame", s.frame,
           "iteration: every step along the three axes of a random orthogonal frame (default: on where an albedo "
           "passes sqrt(3)/2; diffuse scenes)");
    f.row("basis", yes, value("--basis", s.basis, "constant (per patch) | linear (per vertex, Gouraud)"));
    f.row("visibility", yes, value("--visibility", s.visibility, "visibility backend (see `raybundle backends`)"));
    f.row("resolution", yes, cmd.add_option("--resolution", s.map.resolution, "visibility map pixels per side (default: from the scene)")
                                 ->check(kInteger)
                                 ->check(CLI::Range(1, 16384)));
    f.row("refine", yes,
          parsed("--refine",
                 [&c](const std::string& v) {
                     c.config.refine.on = v != "none";
                     if (c.config.refine.on) c.config.refine.growth = std::stod(v);
                 },
                 "refinement driven by the solution: a short pilot solve, then the patches across which the radiance "
                 "varies most are cut until G times the scene's patch count is added (e.g. 1: twice the patches), "
                 "or none")
              ->check(CLI::IsMember({"none"}) | (kFinite & CLI::Range(0.01, 8.0)))
              ->default_str("none"));
    on_off("diffuse_shot", "--diffuse-shot", "--no-diffuse-shot", c.config.diffuse_shot,
           "area lights' direct light once, with shadow rays (004 9.1); default: on for diffuse scenes with area lights");
    f.row("seed", yes, value("--seed", c.config.run.seed, "random seed; the same seed gives bit-identical output")->check(kDigits));
    f.row("shading", yes, parsed("--shading", [&c](const std::string& v) { c.config.shading = render::parse_shading(v); },
                                 "patch image: smooth | flat")
                              ->check(choices(render::kShadingNames))
                              ->default_str(render::shading_name(c.config.shading)));
    f.row("gather_rays", yes, value("--gather", g.gather_rays, "final gather with N rays per pixel for the indirect light (0: the "
                                                               "patch image instead)")
                                  ->check(CLI::Range(0, 1 << 20)));
    f.row("direct_samples", yes, value("--direct-samples", g.direct_samples, "final gather: light sample pairs per camera sample")
                                     ->check(CLI::Range(0, 1 << 16)));
    f.row("spp", yes, value("--spp", g.spp, "final gather: camera samples per pixel (pathtrace: paths per pixel)")
                          ->check(CLI::Range(1, 1 << 20)));
    f.row("emission_samples", yes,
          value("--emission-samples", g.emission_samples, "final gather with --spp > 1: camera rays per pixel, besides the spp "
                                                          "samples, for the emission and sky the camera sees (0: the spp samples see them)")
              ->check(CLI::Range(0, 1 << 16)));
    f.row("direct", yes, parsed("--direct", [&g](const std::string& v) { g.direct = render::parse_direct_light(v); },
                                "final gather, area lights: analytic (exact unoccluded light x shadow ratio, default) | sampled")
                             ->check(choices(render::kDirectLightNames)));
    f.row("direct_at_hits", yes,
          parsed("--direct-at-hits", [&g](const std::string& v) { g.direct_at_hits = v == "on"; },
                 "final gather: on patches across which the lights' direct light varies (shadows' edges, contacts), "
                 "rays reading the field take the direct light at their hit point instead of the patch's: on | off")
              ->check(CLI::IsMember({"on", "off"}))
              ->default_str("on"));
    f.row("glossy_rays", yes, value("--glossy-rays", g.glossy_rays, "final gather: Phong-lobe rays per camera sample on glossy surfaces")
                                  ->check(CLI::Range(0, 1 << 16)));
    f.row("correction", yes,
          parsed("--correction",
                 [&c, &g](const std::string& v) {
                     c.config.auto_correction = v == "auto";
                     g.correction = c.config.auto_correction ? 0.0 : std::stod(v);
                 },
                 "final gather: auto (read the field or correct it, as the bias probe finds pays) or the probability Q "
                 "that a ray reading the solved field goes on and corrects it (the field as a control variate: "
                 "converges to the true image; 0: the field as the answer)")
              ->check(CLI::IsMember({"auto"}) | (kFinite & CLI::Range(0.0, 1.0)))
              ->default_str("auto"));
    f.row("bias_probe", yes, value("--bias-probe", g.bias_probe, "final gather without --correction: probability that a gather "
                                                               "ray is also followed as the correction would, apart from the "
                                                               "image, so that the estimated error sees the field's bias (0: off)")
                                 ->check(kFinite & CLI::Range(0.0, 1.0)));
    f.row("filter", yes, parsed("--filter", [&g](const std::string& v) { g.filter.filter = render::parse_filter(v); },
                                "final gather: guided | bilateral | atrous | none")
                             ->check(choices(render::kFilterNames)));
    f.row("filter_radius", yes, value("--filter-radius", g.filter.radius, "guided and bilateral filters: window radius in pixels (0: 3 "
                                                                          "at 256^2, in proportion to the image size, less with more gather rays per pass)")
                                    ->check(CLI::Range(0, 1024)));
    f.row("eps_normal", yes, value("--eps-normal", g.filter.eps_normal, "guided filter: regularisation of the normals")->check(kPositive));
    f.row("eps_depth", yes, value("--eps-depth", g.filter.eps_depth, "guided filter: regularisation of the depth")->check(kPositive));
    f.row("", no, cmd.add_option("--aov", c.aov, "final gather: also direct, indirect, indirect-filtered, bias, normal, depth EXRs in DIR"));
    f.row("reference", no, cmd.add_option("--reference", c.reference, "an EXR of the same size (e.g. from --method pathtrace): the "
                                                                      "image's relative L1 error, MSE, 4x4-block error and worst 16x16 block against it go into the "
                                                                      "summary line and the stats")
                               ->check(CLI::ExistingFile));
    f.row("target_error", yes, cmd.add_option("--target-error", c.config.rounds.target_error,
                                              "render in rounds until the image's estimated relative L1 error is at most E (e.g. 0.01)")
                                   ->check(kPositive & CLI::Range(0.0, 1.0)));
    f.row("time_budget", yes, cmd.add_option("--time-budget", c.config.rounds.time_budget,
                                             "render in rounds for about S seconds in all, the scene's reading included (the first round always runs)")
                                  ->check(kPositive));
    f.row("", no, cmd.add_option("--stats", c.stats, "run statistics (JSON)"));
    f.row("", no, cmd.add_option("--csv", c.csv, "convergence: iteration,seconds,relative_l1_error,mean_radiance,estimated_error,"
                                                 "round,image_estimated_error,image_relative_l1,image_mse,image_block4_relative_l1,image_worst_block16"));
    f.row("", no, cmd.add_option("--csv-every", c.csv_every, "a convergence row every K steps (default: 100 rows)")
                      ->check(CLI::Range(1L, 1000000000L)));
    f.row("", no, cmd.add_option("--patches", c.patches_csv, "per-patch CSV: id,cx,cy,cz,nx,ny,nz,area,r,g,b"));
    f.row("", no, cmd.add_option("--ply", c.ply, "per-patch PLY with radiance colours (MeshLab)"));
    f.row("", no, cmd.add_flag("-q,--quiet", c.quiet, "no progress bar and no summary line"));
    f.row("checkpoint", no, cmd.add_option("--checkpoint", c.config.checkpoint, "write the solver's state to FILE every "
                                                                                "--checkpoint-every, and when interrupted, to go on with --resume FILE (one-round runs: "
                                                                                "not with --target-error, --time-budget or pathtrace)"));
    f.row("", no, parsed("--checkpoint-every",
                         [&c](const std::string& v) {
                             const bool seconds = v.back() == 's';
                             c.config.checkpoint_seconds = seconds ? std::stod(v.substr(0, v.size() - 1)) : 0.0;
                             c.config.checkpoint_steps = seconds ? 0 : std::stol(v);
                         },
                         "N steps (over both chains, as --iterations counts them) or Ss seconds between checkpoints (default 60s)")
                      ->check(kEvery));
    f.row("resume", no, cmd.add_option("--resume", c.resume, "go on from a checkpoint of the same command (outputs, --threads and "
                                                             "--quiet may differ): the result is bit-identical to an uninterrupted run"));
}

void check_command(const CLI::App& cmd, Command& c) {
    if (c.scene_file.empty() == c.builtin.empty())
        throw UsageError("give exactly one of SCENE.json or --builtin NAME" +
                         (c.scene_file.empty() ? std::string(" (neither given)")
                                               : " (given: " + c.scene_file + " and --builtin " + c.builtin + ")"));
    scenes::Overrides shortcuts;
    shortcuts.swap(c.overrides);
    for (const auto& d : c.defines) {
        const auto eq = d.find('=');
        if (eq == std::string::npos || eq == 0) throw UsageError("-D " + d + ": expected key=value");
        c.overrides.push_back({d.substr(0, eq), d.substr(eq + 1)});
    }
    c.overrides.insert(c.overrides.end(), shortcuts.begin(), shortcuts.end());
    if (cmd.get_name() != "solve") return;

    for (const auto& [on, off] : {std::pair{"--diffuse-shot", "--no-diffuse-shot"}, {"--ambient", "--no-ambient"},
                                  {"--frame", "--no-frame"}})
        if (cmd.count(on) > 0 && cmd.count(off) > 0)
            throw UsageError(std::string("give one of ") + on + " and " + off);
    render::RunConfig& r = c.config;
    if (r.solver.method != "pathtrace") {
        const auto& names = solver::method_names();
        if (std::find(names.begin(), names.end(), r.solver.method) == names.end()) {
            std::string known;
            for (const auto& m : names) known += m + ", ";
            throw UsageError("--method: unknown method '" + r.solver.method + "' (known: " + known + "pathtrace)");
        }
    }
    if (r.solver.method == "pathtrace") {
        for (const char* flag : {"--gather", "--aov", "--direct-samples", "--direct", "--direct-at-hits", "--glossy-rays", "--filter", "--emission-samples",
                                 "--correction", "--bias-probe", "--filter-radius", "--eps-normal", "--eps-depth", "--iterations", "--depth",
                                 "--unbiased", "--sampler", "--basis", "--visibility", "--resolution", "--refine", "--diffuse-shot",
                                 "--no-diffuse-shot", "--one-way", "--both-ways", "--ambient", "--no-ambient", "--frame", "--no-frame", "--csv-every", "--patches", "--ply", "--shading"})
            if (cmd.count(flag) > 0)
                throw UsageError(std::string(flag) + " does not apply to --method pathtrace (no radiance field)");
        for (const auto& image : c.images)
            if (render::is_baked_asset(image))
                throw UsageError("-o " + image + ": a baked asset needs a radiance field (not --method pathtrace)");
        r.path.spp = cmd.count("--spp") > 0 ? r.gather.spp : render::PathTraceOptions{}.spp;
    } else if (r.gather.gather_rays == 0) {
        for (const char* flag : {"--spp", "--aov", "--direct-samples", "--direct", "--direct-at-hits", "--glossy-rays", "--filter", "--emission-samples",
                                 "--correction", "--bias-probe", "--filter-radius", "--eps-normal", "--eps-depth"})
            if (cmd.count(flag) > 0)
                throw UsageError(std::string(flag) + " needs the final gather (--gather N, N > 0)");
    } else if (r.gather.spp > 4096) {
        throw UsageError("--spp " + std::to_string(r.gather.spp) + ": the final gather takes at most 4096");
    }
    if (r.solver.method == "iteration" && cmd.count("--depth") > 0)
        throw UsageError("--depth applies to the walk methods, not to --method iteration");
    for (const char* flag : {"--mutation-size", "--large-step", "--seed-walks"})
        if (cmd.count(flag) > 0 && r.solver.sampler != sampling::SamplerKind::metropolis)
            throw UsageError(std::string(flag) + " applies to --sampler metropolis");
    if (cmd.count("--csv-every") > 0 && c.csv.empty()) throw UsageError("--csv-every needs --csv FILE");
    if (cmd.count("--checkpoint-every") > 0 && r.checkpoint.empty())
        throw UsageError("--checkpoint-every needs --checkpoint FILE");
    for (const auto& [path, flag] : {std::pair{r.checkpoint, "--checkpoint"}, {c.resume, "--resume"}}) {
        if (path.empty()) continue;
        if (r.solver.method == "pathtrace")
            throw UsageError(std::string(flag) + " does not apply to --method pathtrace (no solver state)");
        if (r.rounds.target_error > 0.0 || r.rounds.time_budget > 0.0)
            throw UsageError(std::string(flag) + " works for runs of one round: not with " +
                             (r.rounds.target_error > 0.0 ? "--target-error" : "--time-budget"));
    }
    r.identity = c.flags.identity();
    r.run.progress_every = c.csv_every;
    if (!c.csv.empty()) r.record_every = c.csv_every;
    r.reference_file = c.reference;
    r.resume_file = c.resume;
    // Every output names a file that can be written, and no two outputs, nor an output
    // and an input, the same file (compared once resolved: ./d/x.exr is d/x.exr).
    std::vector<render::NamedFile>& outputs = c.outputs;
    // -o takes images and baked assets (.glb); they part here.
    std::vector<std::string> images;
    c.baked.clear();
    for (const auto& image : c.images) {
        if (render::is_baked_asset(image)) {
            c.baked.push_back(image);
        } else {
            try {
                render::image_format(image);
            } catch (const scenes::OptionError& e) {
                // The formats -o knows: the images', and a baked asset.
                std::string problem = e.problem();
                if (const auto at = problem.rfind(".pfm)"); at != std::string::npos && at + 5 == problem.size())
                    problem.insert(at + 4, "; or .glb, a baked asset");
                throw UsageError("-o " + problem);
            }
            images.push_back(image);
        }
        outputs.push_back({image, "-o"});
    }
    c.images = std::move(images);
    for (const auto& [path, flag] : {std::pair{c.stats, "--stats"}, {c.csv, "--csv"}, {c.patches_csv, "--patches"},
                                     {c.ply, "--ply"}})
        if (!path.empty()) outputs.push_back({path, flag});
    struct stat st {};
    if (!c.aov.empty()) {
        if (::stat(c.aov.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) throw UsageError("--aov " + c.aov + ": not a directory");
        for (const char* name : kAovNames) outputs.push_back({c.aov + "/" + name + ".exr", "--aov"});
    }
    if (!r.checkpoint.empty()) outputs.push_back({r.checkpoint, "--checkpoint"});
    std::vector<render::NamedFile>& inputs = c.inputs;
    if (!c.scene_file.empty()) inputs.push_back({c.scene_file, "the scene file"});
    if (!c.reference.empty()) inputs.push_back({c.reference, "the --reference image"});
    // --resume F --checkpoint F goes on writing the checkpoint it resumed from.
    if (!c.resume.empty() && (r.checkpoint.empty() || render::resolved_path(c.resume) != render::resolved_path(r.checkpoint)))
        inputs.push_back({c.resume, "the --resume checkpoint"});
    render::check_outputs(outputs, inputs);  // OutputError: exit 2
}

scenes::Scene load_scene(const Command& c, const scenes::MemoryShare& memory, ProgressBar& bar,
                         const scenes::PreparationTeam* team) {
    const int threads = c.config.run.threads;
    if (!c.builtin.empty()) return scenes::load_builtin(c.builtin, c.overrides, threads, team, memory);
    PreparationProgress preparation(bar);
    scenes::LoadLimits limits;
    limits.threads = threads;
    limits.team = team;
    limits.memory = memory;
    limits.on_step = [&](const char* step) { preparation.step(step); };
    return scenes::load_scene(c.scene_file, c.overrides, limits);
}

}  // namespace raybundle::apps
