// `raybundle solve`: load -> solve -> render -> write, and the run's record.
#include "checkpoint.h"
#include "cli.h"
#include "memory.h"
#include "outputs.h"
#include "signals.h"
#include "progress.h"
#include "ranks.h"
#include "stats.h"

#include "render/camera.h"
#include "render/gbuffer.h"
#include "render/image_io.h"
#include "render/metrics.h"
#include "render/patch_io.h"
#include "render/progressive.h"
#include "render/scene_check.h"
#include "render/shade.h"
#include "sampling/streams.h"
#include "scenes/ray_caster.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
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

// A row of the convergence CSV: a snapshot of the solve (field columns), or the end
// of a round (the image columns too). Missing values stay empty.
struct Row {
    long steps = 0;
    double seconds = 0.0;
    std::optional<double> error, mean, estimate, image_estimate, image_l1, image_mse;
    long round = 0;
};

// Rows in a checkpoint: the counts, and the values a row has.
constexpr std::pair<const char*, std::optional<double> Row::*> kRowValues[] = {
    {"error", &Row::error},          {"mean", &Row::mean},         {"estimate", &Row::estimate},
    {"image_estimate", &Row::image_estimate}, {"image_l1", &Row::image_l1}, {"image_mse", &Row::image_mse}};

json to_json(const Row& r) {
    json j = {{"steps", r.steps}, {"seconds", r.seconds}, {"round", r.round}};
    for (const auto& [key, value] : kRowValues)
        if (r.*value) j[key] = *(r.*value);
    return j;
}

Row row_from(const json& j) {
    Row r;
    r.steps = j.at("steps").get<long>();
    r.seconds = j.at("seconds").get<double>();
    r.round = j.at("round").get<long>();
    for (const auto& [key, value] : kRowValues)
        if (j.contains(key)) r.*value = j.at(key).get<double>();
    return r;
}

void write_csv(const std::string& path, const std::vector<Row>& rows) {
    render::write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        out << "iteration,seconds,relative_l1_error,mean_radiance,estimated_error,round,image_estimated_error,"
               "image_relative_l1,image_mse\n";
        out.precision(9);
        auto cell = [&](const std::optional<double>& v) {
            out << ',';
            if (v) out << *v;
        };
        for (const auto& r : rows) {
            out << r.steps << ',' << r.seconds;
            for (const auto* v : {&r.error, &r.mean, &r.estimate}) cell(*v);
            out << ',';
            if (r.round > 0) out << r.round;
            for (const auto* v : {&r.image_estimate, &r.image_l1, &r.image_mse}) cell(*v);
            out << '\n';
        }
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

// A result with a non-finite value is a failure that names where it appeared (an
// overflow: coordinates or intensities too large for the arithmetic, or a bug), never
// an output written with exit 0.
void require_finite(const render::Image& image, const std::string& what) {
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x)
            for (int k = 0; k < 3; ++k)
                if (!std::isfinite(image.at(x, y)[k]))
                    throw std::runtime_error(what + ": pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                             ") is not finite (" + std::to_string(image.at(x, y)[k]) +
                                             " in channel " + "rgb"[k] + "); nothing written");
}

std::string object_of(const scenes::Scene& scene, std::size_t patch) {
    const int object = scene.patch_list()[patch].object;
    return object >= 0 && static_cast<std::size_t>(object) < scene.object_names.size()
               ? " (" + scene.object_names[static_cast<std::size_t>(object)] + ")"
               : "";
}

void require_finite(const solver::RadianceField& field, const scenes::Scene& scene) {
    for (std::size_t i = 0; i < field.radiance.size(); ++i)
        for (int k = 0; k < 3; ++k)
            if (!std::isfinite(field.radiance[i][k]))
                throw std::runtime_error("the radiance of patch " + std::to_string(i) + object_of(scene, i) + " is not finite (" +
                                         std::to_string(field.radiance[i][k]) + " in channel " + "rgb"[k] +
                                         "); nothing written");
}

// One chain of the solver, as the image needs it (render/progressive.h): the solver
// reports its progress to whichever callback the current advance() was given.
class SolverChain final : public render::FieldChain {
public:
    SolverChain(const SolverChain&) = delete;  // the solver's callback holds `this`
    SolverChain& operator=(const SolverChain&) = delete;
    SolverChain(const solver::Transport& transport, solver::SolverOptions options, sampling::RunOptions run,
                std::uint64_t chain) {
        run.chain = chain;
        run.progress = [this](const sampling::Progress& p) {
            if (forward_) forward_(p);
        };
        solver_ = solver::make_solver(transport, options, run);
    }
    void advance(long steps, const sampling::ProgressCallback& progress) override {
        forward_ = progress;
        solver_->advance(steps);
        forward_ = nullptr;
    }
    solver::RadianceField field() const override { return solver_->field(); }
    long averaged() const override { return solver_->averaged(); }
    const solver::Solver& solver() const { return *solver_; }
    solver::Solver& solver() { return *solver_; }

private:
    std::unique_ptr<solver::Solver> solver_;
    sampling::ProgressCallback forward_;
};

// Of the first `total` steps of a chain of the run, those of rank `rank`: steps rank,
// rank + ranks, rank + 2 ranks, ... (apps/ranks.h).
long steps_of(long total, int rank, int ranks) { return (total + ranks - 1 - rank) / ranks; }

// Chain h of a run spread over ranks: chain h of every rank, its steps dealt out in
// turn, its field their mean weighted by the steps each averages. Every rank calls
// advance(), field() and averaged() at the same points (the pipeline's control flow
// depends on their results alone, which every rank shares).
class RankedChain final : public render::FieldChain {
public:
    RankedChain(SolverChain& mine, const Ranks& ranks) : mine_(mine), ranks_(ranks) {}
    void advance(long steps, const sampling::ProgressCallback& progress) override {
        const long before = steps_of(total_, ranks_.rank(), ranks_.size());
        total_ += steps;
        mine_.advance(steps_of(total_, ranks_.rank(), ranks_.size()) - before, progress);
        averaged_ = ranks_.sum(mine_.averaged());
    }
    solver::RadianceField field() const override {
        solver::RadianceField f = mine_.field();
        std::vector<double> values;
        values.reserve(3 * f.radiance.size() + 9 * f.corners.size());
        for (const auto& rgb : f.radiance) values.insert(values.end(), rgb.data(), rgb.data() + 3);
        for (const auto& corners : f.corners)
            for (const auto& rgb : corners) values.insert(values.end(), rgb.data(), rgb.data() + 3);
        ranks_.weighted_mean(values, mine_.averaged());
        const double* v = values.data();
        for (auto& rgb : f.radiance) rgb = {v[0], v[1], v[2]}, v += 3;
        for (auto& corners : f.corners)
            for (auto& rgb : corners) rgb = {v[0], v[1], v[2]}, v += 3;
        return f;
    }
    long averaged() const override { return averaged_; }

private:
    SolverChain& mine_;
    const Ranks& ranks_;
    long total_ = 0, averaged_ = 0;
};

// What a run spread over ranks cannot do: one line, before any work.
void require_spreadable(const Command& c, const Ranks& ranks) {
    const std::string n = std::to_string(ranks.size());
    if (c.solver.method == "pathtrace")
        throw UsageError("--method pathtrace runs in one process: it is the reference, not spread over " + n + " ranks");
    if (c.rounds.time_budget > 0.0)
        throw UsageError("--time-budget on " + n + " ranks: how far the rounds go would depend on the machines' speed; "
                         "give --iterations or --target-error");
    if (!c.checkpoint.empty() || !c.resume.empty())
        throw UsageError(std::string(c.checkpoint.empty() ? "--resume" : "--checkpoint") +
                         " works in one process, not on " + n + " ranks");
    if (2 * static_cast<std::uint64_t>(ranks.size()) > sampling::streams::kMaxChains)
        throw UsageError(n + " ranks: at most " + std::to_string(sampling::streams::kMaxChains / 2) +
                         " (two independent chains each)");
}

// Every rank must solve the same scene with the same options (the scene files of
// every node the same): a hash of the run's identity, compared with rank 0's.
void require_same_everywhere(const json& identity, const Ranks& ranks) {
    const std::uint64_t h = identity_hash(identity);
    if (ranks.from_leader(h) != h)
        throw UsageError("the scene " + identity["scene"]["name"].get<std::string>() + " (" +
                         std::to_string(identity["scene"]["patches"].get<std::size_t>()) +
                         " patches) or the options differ from rank 0's: every node must read the same scene file "
                         "and be given the same options");
}

// Both chains' work in one report: counts and seconds added, the rest from chain 0.
solver::SolverReport combined(const solver::SolverReport& a, const solver::SolverReport& b) {
    solver::SolverReport r = a;
    r.steps += b.steps;
    r.directions += b.directions;
    r.seconds_visibility += b.seconds_visibility;
    r.seconds_transport += b.seconds_transport;
    r.entries_total += b.entries_total;
    return r;
}

json rounds_record(const render::Rounds& r, const render::RoundOptions& o) {
    json rounds = json::array();
    for (const auto& k : r.rounds)
        rounds.push_back(
            {{"scale", k.scale}, {"steps", k.steps}, {"seconds", k.seconds}, {"estimated_error", k.estimate}});
    json out = {{"image_estimated_error", r.estimate}, {"scale", r.scale}, {"stopped", r.stopped}, {"rounds", rounds}};
    if (r.field_share >= 0.0) {
        out["field_share"] = r.field_share;
        out["steps_share"] = r.steps_share;
    }
    if (o.target_error > 0.0) out["target_error"] = o.target_error;
    if (o.time_budget > 0.0) out["time_budget"] = o.time_budget;
    return out;
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

void print_estimate(const render::Rounds& r) {
    if (r.estimate >= 0.0)
        std::printf(", estimated error %.2g %% (%zu round%s)", 100.0 * r.estimate, r.rounds.size(),
                    r.rounds.size() == 1 ? "" : "s");
}

void print_written(std::vector<std::string> written) {
    std::string wrote;
    for (const auto& path : written) wrote += (wrote.empty() ? "" : ", ") + path;
    if (!wrote.empty()) std::printf("; wrote %s", wrote.c_str());
    std::printf("\n");
}

// A CSV row at the end of a round: the image's estimate, and its true error where a
// reference is given.
void add_image_columns(Row& row, const render::Snapshot& s, const std::optional<render::Image>& reference) {
    row.round = s.round;
    row.image_estimate = s.image_estimate;
    if (const auto against = compare(reference, *s.image)) {
        row.image_l1 = against->relative_l1;
        row.image_mse = against->mse;
    }
}

// The chains restored from a checkpoint, checked against the run: a state of another
// method or option set, or more steps than the run's, is a wrong --resume file.
void resume_chains(const std::string& file, const Checkpoint& k, const std::array<solver::Solver*, 2>& chains,
                   long steps_per_chain) {
    for (std::size_t h = 0; h < 2; ++h) {
        try {
            solver::StateReader in(k.states[h]);
            chains[h]->restore(in);
            in.finish();
        } catch (const solver::StateError& e) {
            throw UsageError("--resume " + file + ": chain " + std::to_string(h) + ": " + e.what());
        }
    }
    if (k.steps_done < 0 || k.steps_done > steps_per_chain || chains[0]->report().steps != k.steps_done)
        throw UsageError("--resume " + file + ": " + std::to_string(k.steps_done) + " steps done does not fit the run's " +
                         std::to_string(steps_per_chain));
}

std::vector<Row> rows_from(const std::string& file, const json& saved) {
    std::vector<Row> rows;
    try {
        for (const auto& r : saved) rows.push_back(row_from(r));
    } catch (const json::exception& e) {
        throw UsageError("--resume " + file + ": its convergence rows are damaged (" + e.what() + ")");
    }
    return rows;
}

// What happens between steps (render::FieldImageOptions::pause): a checkpoint when one
// is due (every --checkpoint-every steps or seconds, and when a signal stops the run),
// and false once a signal asked the run to stop (apps/signals.h). The seconds in a
// checkpoint are the solve's, a resumed run's before included.
class Pauses {
public:
    Pauses(const Command& c, const Ranks& ranks, json identity, std::array<solver::Solver*, 2> chains,
           const std::vector<Row>& rows, long resumed_steps, double seconds_before)
        : c_(c), ranks_(ranks), identity_(std::move(identity)), chains_(chains), rows_(rows),
          seconds_before_(seconds_before),
          next_(c.checkpoint_steps > 0 ? (2 * resumed_steps / c.checkpoint_steps + 1) * c.checkpoint_steps : 0) {}

    bool operator()(long done) {
        // Spread over ranks, they stop together: at the first pause where any has a signal.
        const int sig = ranks_.spread() ? ranks_.max(stop_requested()) : stop_requested();
        signal_ = sig;
        if (!c_.checkpoint.empty()) {
            const bool due = sig != 0 || (c_.checkpoint_steps > 0 && 2 * done >= next_) ||
                             (c_.checkpoint_seconds > 0.0 && since(last_) >= c_.checkpoint_seconds);
            if (due && done != checkpointed_) {
                try {
                    save(done);
                } catch (const std::exception& e) {
                    // A full disk must not end the run: the previous checkpoint stays, and
                    // the next one is tried when due.
                    std::cerr << "\nraybundle: warning: " << e.what() << "; the run goes on\n";
                }
                last_ = Clock::now();
                while (c_.checkpoint_steps > 0 && next_ <= 2 * done) next_ += c_.checkpoint_steps;
            }
        }
        return sig == 0;
    }
    // The steps per chain of the last checkpoint written (-1: none).
    long checkpointed() const { return checkpointed_; }
    // The signal that stopped the run, as of the last pause (every rank's).
    int signal() const { return signal_; }

private:
    void save(long done) {
        Checkpoint k;
        k.identity = identity_;
        k.steps_done = done;
        k.seconds = seconds_before_ + since(start_);
        for (const auto& r : rows_) k.rows.push_back(to_json(r));
        for (const solver::Solver* chain : chains_) {
            solver::StateWriter out;
            chain->save(out);
            k.states.push_back(out.bytes());
        }
        write_checkpoint(c_.checkpoint, k);
        checkpointed_ = done;
    }

    const Command& c_;
    const Ranks& ranks_;
    json identity_;
    std::array<solver::Solver*, 2> chains_;
    const std::vector<Row>& rows_;
    double seconds_before_;
    long next_;  // the step count (both chains) of the next checkpoint by steps
    Clock::time_point start_ = Clock::now(), last_ = start_;
    long checkpointed_ = -1;
    int signal_ = 0;
};

// `--method pathtrace`: the reference image, no radiance field.
int path_trace(const Command& c, const scenes::Scene& scene, const scenes::RayCaster& caster,
               const sampling::RunOptions& run, ProgressBar& bar, Clock::time_point t_start,
               const std::optional<render::Image>& reference) {
    const render::PinholeCamera camera(scene.camera);
    std::vector<Row> rows;
    const auto traced = render::traced_image(scene, caster, camera, c.path, c.rounds, run, [&](const render::Snapshot& s) {
        Row row;
        row.seconds = s.seconds;
        add_image_columns(row, s, reference);
        rows.push_back(row);
    });
    bar.clear();
    require_finite(traced.traced.image, "the image");
    const auto against = compare(reference, traced.traced.image);
    OutputSet outputs;
    for (const auto& path : c.images)
        outputs.stage(path, [&](const std::string& tmp) { render::write_image(tmp, traced.traced.image, c.exposure); });
    if (!c.csv.empty()) outputs.stage(c.csv, [&](const std::string& tmp) { write_csv(tmp, rows); });
    json stats = {{"scene", scene.name},
                  {"patches", scene.patch_count()},
                  {"method", "pathtrace"},
                  {"seed", c.run.seed},
                  {"threads_requested", c.run.threads},
                  {"image", {{"width", scene.camera.width}, {"height", scene.camera.height}}},
                  {"path_trace",
                   {{"spp", c.path.spp}, {"paths", traced.traced.paths}, {"rays", traced.traced.rays}}},
                  {"estimate", rounds_record(traced.rounds, c.rounds)},
                  {"seconds_render", traced.traced.seconds},
                  {"seconds_total", since(t_start)},
                  {"decisions",
                   {{"image", "brute-force path tracing: next-event estimation and BRDF sampling with the balance "
                              "heuristic, Russian roulette; unbiased (render/path_tracer.h)"},
                    {"rounds", traced.rounds.stopped}}}};
    record(stats, c, against);
    if (!c.stats.empty()) outputs.stage(c.stats, [&](const std::string& tmp) { write_json(tmp, stats); });
    outputs.commit();
    if (!c.quiet) {
        std::printf("%s: %zu patches, path traced %ld paths per pixel in %.2f s", scene.name.c_str(),
                    scene.patch_count(), traced.traced.paths / (static_cast<long>(scene.camera.width) * scene.camera.height),
                    traced.traced.seconds);
        print_estimate(traced.rounds);
        print_against(against);
        std::vector<std::string> written = c.images;
        for (const auto* path : {&c.csv, &c.stats})
            if (!path->empty()) written.push_back(*path);
        print_written(written);
    }
    return 0;
}

}  // namespace

int solve(const Command& c, Ranks& ranks) {
    const auto t_start = Clock::now();
    install_signal_handlers();
    if (ranks.spread()) require_spreadable(c, ranks);
    ProgressBar bar(c.quiet || !ranks.leader());
    sampling::RunOptions run = c.run;
    run.progress = [&](const sampling::Progress& p) { bar(p); };
    if (ranks.spread()) run.team = &ranks;

    // The checkpoint to go on from: read first (a wrong file stops the run at once), its
    // run checked against this one once the scene is loaded.
    std::optional<Checkpoint> resumed;
    if (!c.resume.empty()) resumed = read_checkpoint(c.resume);
    const scenes::Scene scene = load_scene(c);
    require_memory(c, scene);
    const json identity = run_identity(c, scene);
    if (resumed) require_same_run(c.resume, resumed->identity, identity);
    if (ranks.spread()) require_same_everywhere(identity, ranks);
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
    // Two independent chains, whose difference estimates the error (render/progressive.h).
    // Spread over ranks, each runs its share of both (RankedChain).
    solver::SolverOptions per_chain = c.solver;
    per_chain.steps = render::chain_steps(c.solver.steps, c.rounds);
    solver::SolverOptions mine = per_chain;
    mine.steps = std::max(1L, steps_of(per_chain.steps, ranks.rank(), ranks.size()));
    const auto first_chain = 2 * static_cast<std::uint64_t>(ranks.rank());
    SolverChain chain_a(transport, mine, run, first_chain), chain_b(transport, mine, run, first_chain + 1);
    RankedChain ranked_a(chain_a, ranks), ranked_b(chain_b, ranks);
    render::FieldChain& run_a = ranks.spread() ? static_cast<render::FieldChain&>(ranked_a) : chain_a;
    render::FieldChain& run_b = ranks.spread() ? static_cast<render::FieldChain&>(ranked_b) : chain_b;
    // What the method converges to on a scene with a known answer (walks truncated at D
    // bounces: a known fraction of it on a homogeneous scene).
    std::optional<double> exact;
    if (scene.exact_radiance) {
        exact = scene.exact_radiance;
        if (scene.homogeneous_albedo) *exact *= chain_a.solver().converged_fraction(*scene.homogeneous_albedo);
    }

    render::FieldImageOptions image_options;
    image_options.steps = c.solver.steps;
    image_options.gather = c.gather_rays > 0;
    image_options.gather_options = c.gather;
    image_options.shading = render::parse_shading(c.shading);
    std::vector<Row> rows;
    double seconds_before = 0.0;  // of a resumed run's solve
    if (!c.csv.empty()) image_options.record_every = c.csv_every > 0 ? c.csv_every : std::max(2L, c.solver.steps / 100);
    const auto observe = [&](const render::Snapshot& s) {
        if (c.csv.empty()) return;
        Row row;
        row.steps = s.steps;
        row.seconds = seconds_before + s.seconds;
        if (exact) row.error = s.field->relative_l1_error(scene, *exact);
        row.mean = s.field->mean_radiance(scene);
        if (s.field_estimate >= 0.0) row.estimate = s.field_estimate;
        if (s.image) add_image_columns(row, s, reference);
        rows.push_back(row);
    };
    // Going on from a checkpoint; checkpoints and stops between steps.
    if (resumed) {
        resume_chains(c.resume, *resumed, {&chain_a.solver(), &chain_b.solver()}, per_chain.steps);
        image_options.resume_steps = resumed->steps_done;
        seconds_before = resumed->seconds;
        rows = rows_from(c.resume, resumed->rows);
    }
    Pauses pauses(c, ranks, identity, {&chain_a.solver(), &chain_b.solver()}, rows, image_options.resume_steps,
                  seconds_before);
    image_options.pause = [&pauses](long done) { return pauses(done); };
    // Pauses no shorter than the solver's batches of directions (4 per thread).
    image_options.pause_every = std::max(16L, 4L * c.run.threads);
    // From here a first signal stops the solve and makes the image of the steps done.
    set_stoppable(true);
    const render::PinholeCamera camera(scene.camera);
    std::optional<render::FieldImage> made_or_none;
    try {
        made_or_none = render::field_image(scene, caster, camera, run_a, run_b, image_options, c.rounds, run, observe);
    } catch (const render::Interrupted& e) {
        bar.clear();
        const int sig = ranks.spread() ? pauses.signal() : stop_requested();
        std::cerr << "raybundle: " << signal_name(sig) << ": " << e.what() << ", nothing written"
                  << (pauses.checkpointed() >= 0 ? "; the checkpoint " + c.checkpoint + " holds the steps done" : "")
                  << "\n";
        return 128 + sig;
    }
    const render::FieldImage& made = *made_or_none;
    bar.clear();
    const render::Image& image = made.image;
    const solver::RadianceField& field = made.field;
    const auto against = compare(reference, image);

    require_finite(field, scene);
    require_finite(image, "the image");
    // Every rank's work in the report; then rank 0 alone writes.
    solver::SolverReport report = combined(chain_a.solver().report(), chain_b.solver().report());
    if (ranks.spread()) {
        report.steps = ranks.sum(report.steps);
        report.directions = ranks.sum(report.directions);
        report.entries_total = static_cast<std::size_t>(ranks.sum(static_cast<long>(report.entries_total)));
        report.seconds_visibility = ranks.sum(report.seconds_visibility);
        report.seconds_transport = ranks.sum(report.seconds_transport);
    }
    ranks.finish();
    const int sig = ranks.spread() ? pauses.signal() : stop_requested();
    if (!ranks.leader()) return sig != 0 ? 128 + sig : 0;
    // The outputs asked for, all written or none (apps/outputs.h).
    OutputSet outputs;
    for (const auto& path : c.images)
        outputs.stage(path, [&](const std::string& tmp) { render::write_image(tmp, image, c.exposure); });
    if (made.gather && !c.aov.empty()) {
        const auto& g = *made.gather;
        const render::Image* aovs[] = {&g.direct, &g.indirect, &g.indirect_filtered, &g.normal, &g.depth};
        static_assert(std::size(aovs) == kAovNames.size());
        for (std::size_t i = 0; i < kAovNames.size(); ++i)
            outputs.stage(c.aov + "/" + kAovNames[i] + ".exr",
                          [&](const std::string& tmp) { render::write_exr(tmp, *aovs[i]); });
    }
    if (!c.patches_csv.empty())
        outputs.stage(c.patches_csv, [&](const std::string& tmp) { render::write_patch_csv(tmp, scene, field); });
    if (!c.ply.empty())
        outputs.stage(c.ply, [&](const std::string& tmp) { render::write_patch_ply(tmp, scene, field, c.exposure); });
    if (!c.csv.empty()) outputs.stage(c.csv, [&](const std::string& tmp) { write_csv(tmp, rows); });

    const double mean = field.mean_radiance(scene);
    json stats = run_record(scene, c, report, transport, summary.overlaps.pairs);
    const double seconds_solve = made.rounds.seconds_solve, seconds_render = made.rounds.seconds_render;
    stats["chains"] = 2 * ranks.size();
    stats["ranks"] = ranks.size();
    stats["seconds_total"] = since(t_start);
    stats["seconds_solve"] = seconds_solve;
    stats["seconds_render"] = seconds_render;
    // This run's steps only (a resumed run's solver counts the steps before it too).
    const long steps_here = made.steps - 2 * image_options.resume_steps;
    const double directions_per_step = report.steps > 0 ? static_cast<double>(report.directions) / report.steps : 1.0;
    stats["seconds_per_iteration"] = steps_here > 0 ? seconds_solve / steps_here : 0.0;
    stats["seconds_per_direction"] = steps_here > 0 ? seconds_solve / (steps_here * directions_per_step) : 0.0;
    stats["mean_radiance"] = mean;
    if (made.gather) stats["final_gather"] = gather_record(c, *made.gather);
    json estimate = rounds_record(made.rounds, c.rounds);
    estimate["field_estimated_error"] = made.field_estimate;
    stats["estimate"] = estimate;
    stats["decisions"]["diffuse_shot_choice"] = shot_choice;
    stats["decisions"]["image"] = made.gather ? "final gather: direct light per sample, indirect at guide rays, " +
                                                    std::string(render::filter_name(c.gather.filter.filter)) + " filter"
                                              : "the patch radiance (" + c.shading + " shading); --gather N for a final gather";
    stats["decisions"]["rounds"] = made.rounds.stopped;
    stats["partial"] = made.rounds.interrupted;
    if (sig != 0) stats["interrupted_by"] = signal_name(sig);
    stats["steps_planned"] = 2 * per_chain.steps;
    if (resumed)
        stats["resumed"] = {{"checkpoint", c.resume}, {"steps_done", 2 * resumed->steps_done}, {"seconds_before", seconds_before}};
    if (!c.checkpoint.empty())
        stats["checkpoint"] = {{"file", c.checkpoint}, {"steps", 2 * std::max(0L, pauses.checkpointed())}};
    std::optional<double> error;
    if (exact) {
        error = field.relative_l1_error(scene, *exact);
        stats["exact_radiance"] = *exact;
        stats["relative_l1_error"] = *error;
    }
    record(stats, c, against);
    if (!c.stats.empty()) outputs.stage(c.stats, [&](const std::string& tmp) { write_json(tmp, stats); });
    outputs.commit();

    if (!c.quiet) {
        std::printf("%s: %zu patches, %s %ld steps in %.2f s", scene.name.c_str(), scene.patch_count(),
                    report.method.c_str(), report.steps, seconds_solve);
        if (made.gather) std::printf(", final gather %.2f s", seconds_render);
        std::printf(", mean radiance %.6g", mean);
        if (error) std::printf(", relative L1 error %.3g", *error);
        print_estimate(made.rounds);
        print_against(against);
        std::vector<std::string> written = c.images;
        if (made.gather && !c.aov.empty()) written.push_back(c.aov + "/");
        for (const auto* path : {&c.stats, &c.csv, &c.patches_csv, &c.ply})
            if (!path->empty()) written.push_back(*path);
        print_written(written);
    }
    if (sig != 0) {
        std::cerr << "raybundle: " << signal_name(sig) << ": "
                  << (made.rounds.interrupted ? "stopped after " + std::to_string(made.steps) + " of " +
                                                    std::to_string(2 * per_chain.steps) +
                                                    " steps; the outputs are of the steps done (\"partial\" in the stats)"
                                              : "the run was complete; its outputs are written")
                  << (made.rounds.interrupted && pauses.checkpointed() >= 0 ? "; go on with --resume " + c.checkpoint
                                                                             : "")
                  << "\n";
        return 128 + sig;
    }
    return 0;
}

}  // namespace raybundle::apps
