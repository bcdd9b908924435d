#include "render/run.h"

#include "render/camera.h"
#include "render/image_io.h"
#include "render/memory.h"
#include "render/metrics.h"
#include "render/run_record.h"
#include "render/scene_check.h"
#include "sampling/streams.h"
#include "scenes/errors.h"
#include "scenes/ray_caster.h"
#include "scenes/subdivide.h"
#include "scenes/threads.h"
#include "visibility/backend.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <mutex>
#include <optional>

namespace raybundle::render {

namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Warnings passed on the first time each, the lines that came again counted: the count
// is passed on when it ends ("<line> (N times)").
class OnceEach {
public:
    explicit OnceEach(std::function<void(const std::string&)> out) : out_(std::move(out)) {}
    ~OnceEach() {
        try {
            for (const auto& [line, times] : seen_)
                if (times > 1) out_(line + " (" + std::to_string(times) + " times)");
        } catch (...) {  // a warning lost rather than an exception from a destructor
        }
    }
    OnceEach(const OnceEach&) = delete;
    OnceEach& operator=(const OnceEach&) = delete;
    void operator()(const std::string& line) {
        const std::lock_guard<std::mutex> guard(lock_);
        auto it = std::find_if(seen_.begin(), seen_.end(), [&](const auto& s) { return s.first == line; });
        if (it != seen_.end()) {
            ++it->second;
            return;
        }
        seen_.emplace_back(line, 1);
        out_(line);
    }

private:
    std::function<void(const std::string&)> out_;
    std::vector<std::pair<std::string, long>> seen_;  // in order of first appearance
    std::mutex lock_;
};

// The warnings a scene deserves before it is solved, one line each.
void warn_about(const scenes::Scene& scene, const SceneSummary& summary, const RunHooks& hooks) {
    if (!hooks.warn) return;
    const auto& overlaps = summary.overlaps;
    if (scene.dropped_degenerate > 0) hooks.warn(scene.name + ": " + scene.dropped_summary());
    if (overlaps.pairs > 0)
        hooks.warn(scene.name + ": " + std::to_string(overlaps.pairs) +
                   " pairs of coplanar overlapping patches face the same way (e.g. " + overlap_example(scene, overlaps) +
                   "): no visibility map can order them; the higher patch index is in front");
    for (const auto& line : scene.warnings) hooks.warn(line);
    // (An OBJ or glTF file alone names its parts "room.obj: lamp": not "room.obj: room.obj: lamp".)
    const std::string prefix = scene.name + ": ",
                      file = scene.name.substr(scene.name.find_last_of('/') == std::string::npos ? 0 : scene.name.find_last_of('/') + 1) + ": ";
    for (const auto& line : winding_warnings(summary))
        hooks.warn(line.rfind(prefix, 0) == 0 || line.rfind(file, 0) == 0 ? line : prefix + line);
    for (const auto& line : light_warnings(scene, summary)) hooks.warn(prefix + line);
    if (!has_light(scene)) hooks.warn(scene.name + ": " + kNoLight);
}

// A result with a non-finite value is a failure that names where it appeared (an
// overflow: coordinates or intensities too large for the arithmetic, or a bug), never
// an output.
void require_finite(const Image& image, const std::string& what) {
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
                throw std::runtime_error("the radiance of patch " + std::to_string(i) + object_of(scene, i) +
                                         " is not finite (" + std::to_string(field.radiance[i][k]) + " in channel " +
                                         "rgb"[k] + "); nothing written");
}

// One chain of the solver, as the image needs it (render/progressive.h): the solver
// reports its progress to whichever callback the current advance() was given.
class SolverChain final : public FieldChain {
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
    // The solver reports as it finishes a step: each finish forwards to `progress`
    // (a stream's finishes run one at a time), and nothing does once the stream is gone.
    std::optional<solver::StepStream> stream(long steps, const sampling::ProgressCallback& progress) override {
        auto made = solver_->stream(steps, true);
        if (made)
            made->finish = [this, finish = std::move(made->finish), progress](long item, long slot) {
                forward_ = progress;
                struct Unset {
                    sampling::ProgressCallback& f;
                    ~Unset() { f = nullptr; }
                } unset{forward_};
                finish(item, slot);
            };
        return made;
    }
    solver::RadianceField field(int threads = 0) const override { return solver_->field(threads); }
    long averaged() const override { return solver_->averaged(); }
    const solver::Solver& solver() const { return *solver_; }
    solver::Solver& solver() { return *solver_; }

private:
    std::unique_ptr<solver::Solver> solver_;
    sampling::ProgressCallback forward_;
};

// Of the first `total` steps of a chain of the run, those of member `rank`: steps
// rank, rank + members, rank + 2 members, ...
long steps_of(long total, int rank, int members) { return (total + members - 1 - rank) / members; }

// Chain h of a run spread over a team: chain h of every member, its steps dealt out in
// turn, its field their mean weighted by the steps each averages. Every member calls
// advance(), field() and averaged() at the same points (the pipeline's control flow
// depends on their results alone, which every member shares).
class TeamChain final : public FieldChain {
public:
    TeamChain(SolverChain& mine, const sampling::Team& team) : mine_(mine), team_(team) {}
    void advance(long steps, const sampling::ProgressCallback& progress) override {
        const long before = steps_of(total_, team_.rank(), team_.size());
        total_ += steps;
        mine_.advance(steps_of(total_, team_.rank(), team_.size()) - before, progress);
        averaged_ = team_.sum(mine_.averaged());
    }
    solver::RadianceField field(int threads = 0) const override {
        solver::RadianceField f = mine_.field(threads);
        std::vector<double> values;
        values.reserve(3 * f.radiance.size() + 9 * f.corners.size());
        for (const auto& rgb : f.radiance) values.insert(values.end(), rgb.data(), rgb.data() + 3);
        for (const auto& corners : f.corners)
            for (const auto& rgb : corners) values.insert(values.end(), rgb.data(), rgb.data() + 3);
        team_.weighted_mean(values, mine_.averaged());
        const double* v = values.data();
        for (auto& rgb : f.radiance) rgb = {v[0], v[1], v[2]}, v += 3;
        for (auto& corners : f.corners)
            for (auto& rgb : corners) rgb = {v[0], v[1], v[2]}, v += 3;
        return f;
    }
    long averaged() const override { return averaged_; }

private:
    SolverChain& mine_;
    const sampling::Team& team_;
    long total_ = 0, averaged_ = 0;
};

// Every member must solve the same scene with the same options (the scene files of
// every node the same): a hash of the run's identity, compared with member 0's.
void require_same_everywhere(const json& identity, const sampling::Team& team) {
    const std::uint64_t h = identity_hash(identity);
    if (team.from_leader(h) != h)
        throw RunError("the scene " + identity["scene"]["name"].get<std::string>() + " (" +
                       std::to_string(identity["scene"]["patches"].get<std::size_t>()) +
                       " patches) or the options differ from rank 0's: every node must read the same scene file "
                       "and be given the same options");
}

// The rounds' options: a time budget less what the scene's reading and the run's
// preparation took. Where that leaves nothing, the first round runs all the same and a
// warning says so, with the least the scene takes.
RoundOptions rounds_left(const RunConfig& c, double seconds_run, const RunHooks& hooks) {
    RoundOptions o = c.rounds;
    if (!(o.time_budget > 0.0)) return o;
    const double spent = c.seconds_spent + seconds_run;
    if (spent >= o.time_budget) {
        if (hooks.warn) {
            char line[256];
            std::snprintf(line, sizeof line,
                          "--time-budget %g: preparing the scene took %.2f s of it, nothing is left for the image; "
                          "one first round runs (the least this scene takes: that preparation and one round)",
                          o.time_budget, spent);
            hooks.warn(line);
        }
        o.time_budget = 1e-9;  // not 0, which means no budget: the first round alone
    } else {
        o.time_budget -= spent;
    }
    return o;
}

// A time budget the first round alone overran (it always runs): the least this scene
// takes with these flags, said once the run knows it.
void warn_if_over(const RunConfig& c, const scenes::Scene& scene, const Rounds& rounds, double seconds,
                  const RunHooks& hooks) {
    const double S = c.rounds.time_budget;
    if (!(S > 0.0) || seconds <= 1.15 * S + 0.5 || rounds.rounds.size() != 1 || !hooks.warn) return;
    char line[320];
    std::snprintf(line, sizeof line,
                  "--time-budget %g: the first round took %.2f s and the run %.2f s, "
                  "the least this scene takes at %dx%d with these flags (a smaller image, fewer --spp or "
                  "--direct-samples take less)",
                  S, rounds.rounds.front().seconds, seconds, scene.camera.width, scene.camera.height);
    hooks.warn(line);
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

std::optional<ImageError> compare(const std::optional<Image>& ref, const Image& image) {
    if (!ref) return std::nullopt;
    return image_error(image, *ref);
}

// A CSV row at the end of a round: the image's estimate, and its true error where a
// reference is given.
void add_image_columns(ConvergenceRow& row, const Snapshot& s, const std::optional<Image>& reference) {
    row.round = s.round;
    row.image_estimate = s.image_estimate;
    if (const auto against = compare(reference, *s.image)) {
        row.image_l1 = against->relative_l1;
        row.image_mse = against->mse;
        row.image_block4_l1 = against->block4_l1;
        row.image_worst_block16 = against->worst_block16;
    }
}

// The chains restored from a checkpoint, checked against the run: a state of another
// method or option set, or more steps than the run's, is another run's checkpoint.
void resume_chains(const std::string& file, const Checkpoint& k, const std::array<solver::Solver*, 2>& chains,
                   long steps_per_chain) {
    for (std::size_t h = 0; h < 2; ++h) {
        try {
            solver::StateReader in(k.states[h]);
            chains[h]->restore(in);
            in.finish();
        } catch (const solver::StateError& e) {
            throw CheckpointError(file + ": chain " + std::to_string(h) + ": " + e.what());
        }
    }
    if (k.steps_done < 0 || k.steps_done > steps_per_chain)
        throw CheckpointError(file + ": " + std::to_string(k.steps_done) + " steps done does not fit the run's " +
                              std::to_string(steps_per_chain));
    // Both chains' counters as the header says: the steps done, and the steps their
    // fields average (no more than the steps done).
    for (std::size_t h = 0; h < 2; ++h)
        if (chains[h]->report().steps != k.steps_done || chains[h]->averaged() < 0 ||
            chains[h]->averaged() > k.steps_done)
            throw CheckpointError(file + ": chain " + std::to_string(h) + " counts " +
                                  std::to_string(chains[h]->report().steps) + " steps done and averages " +
                                  std::to_string(chains[h]->averaged()) + ", the header says " +
                                  std::to_string(k.steps_done) + " steps done (a damaged file)");
}

std::vector<ConvergenceRow> rows_from(const std::string& file, const json& saved) {
    std::vector<ConvergenceRow> rows;
    try {
        for (const auto& r : saved) rows.push_back(row_from_json(r));
    } catch (const json::exception& e) {
        throw CheckpointError(file + ": its convergence rows are damaged (" + e.what() + ")");
    }
    return rows;
}

// What happens between steps (FieldImageOptions::pause): a checkpoint when one is due
// (every checkpoint_steps steps or checkpoint_seconds, and when a stop is asked for),
// and false once a stop is asked for. Spread over a team, the members stop together.
// The seconds in a checkpoint are the solve's, a resumed run's before included.
class Pauses {
public:
    Pauses(const RunConfig& c, const RunHooks& hooks, json identity, std::array<solver::Solver*, 2> chains,
           const std::vector<ConvergenceRow>& rows, long resumed_steps, double seconds_before)
        : c_(c), hooks_(hooks), identity_(std::move(identity)), chains_(chains), rows_(rows),
          seconds_before_(seconds_before),
          next_(c.checkpoint_steps > 0 ? (2 * resumed_steps / c.checkpoint_steps + 1) * c.checkpoint_steps : 0) {}

    bool operator()(long done) {
        const int asked = hooks_.stop_requested ? hooks_.stop_requested() : 0;
        const sampling::Team* team = c_.run.team;
        const int sig = team && team->size() > 1 ? team->max(asked) : asked;
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
                    if (hooks_.warn) hooks_.warn(std::string("checkpoint ") + e.what() + "; the run goes on");
                }
                last_ = Clock::now();
                while (c_.checkpoint_steps > 0 && next_ <= 2 * done) next_ += c_.checkpoint_steps;
            }
        }
        return sig == 0;
    }
    long checkpointed() const { return checkpointed_; }
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
        write_checkpoint(c_.checkpoint, k, hooks_.temporaries);
        checkpointed_ = done;
    }

    const RunConfig& c_;
    const RunHooks& hooks_;
    json identity_;
    std::array<solver::Solver*, 2> chains_;
    const std::vector<ConvergenceRow>& rows_;
    double seconds_before_;
    long next_;  // the step count (both chains) of the next checkpoint by steps
    Clock::time_point start_ = Clock::now(), last_ = start_;
    long checkpointed_ = -1;
    int signal_ = 0;
};

// The diffuse shot: as given, or on for diffuse scenes with area lights, whose direct
// light it makes exact up to its quadrature. The decision and why.
std::pair<bool, std::string> decide_diffuse_shot(const scenes::Scene& scene, const std::optional<bool>& given) {
    if (given) return {*given, std::string(*given ? "--diffuse-shot" : "--no-diffuse-shot") + " given"};
    const bool on = scene.has_emission() && !scene.has_glossy();
    return {on, on                   ? "on: a diffuse scene with area lights"
                : scene.has_glossy() ? "off: the scene has glossy materials"
                                     : "off: the scene has no area lights"};
}

// `--method pathtrace`: the reference image, no radiance field.
RunResult path_trace_run(const scenes::Scene& scene, const scenes::RayCaster& caster, const RunConfig& c,
                         const RoundOptions& rounds, Clock::time_point t_start) {
    const PinholeCamera camera(scene.camera);
    RunResult out;
    const auto traced = traced_image(scene, caster, camera, c.path, rounds, c.run, [&](const Snapshot& s) {
        ConvergenceRow row;
        row.seconds = s.seconds;
        add_image_columns(row, s, c.reference);
        out.rows.push_back(row);
    });
    require_finite(traced.traced.image, "the image");
    out.image = traced.traced.image;
    out.rounds = traced.rounds;
    out.against = compare(c.reference, out.image);
    out.record = path_trace_record(scene, c, traced, since(t_start));
    record_reference(out.record, c, out.against);
    return out;
}

// The pilot of the refinement driven by the solution (render/adaptive.h): the shots and
// two short chains on the scene as given, with random streams of their own (another
// seed: the run's chains do not see the noise the cuts were chosen on), and the scene
// cut where their radiance varies. Its progress is the phase "refine".
struct Refined {
    scenes::Scene scene;
    json record;
    std::string decision;
    double seconds = 0.0;
};

Refined refined_by_solution(const scenes::Scene& scene, const RunConfig& c) {
    const auto t0 = Clock::now();
    sampling::RunOptions run = c.run;
    run.team = nullptr;  // every member of a team makes the same pilot, alone
    run.seed = c.run.seed ^ 0x9e3779b97f4a7c15ULL;
    run.progress = [&c](const sampling::Progress& p) {
        if (!c.run.progress) return;
        sampling::Progress q = p;
        q.phase = "refine";
        c.run.progress(q);
    };
    solver::ShotOptions shots = c.shots;
    shots.diffuse_shot = decide_diffuse_shot(scene, c.diffuse_shot).first;
    const scenes::RayCaster caster(scene, c.run.threads);
    const solver::Transport transport(scene, shots, run, &caster);
    solver::SolverOptions options = c.solver;
    options.steps = c.refine.pilot_steps;
    SolverChain a(transport, options, run, 0), b(transport, options, run, 1);
    a.advance(options.steps, run.progress);
    b.advance(options.steps, run.progress);
    const std::vector<double> varies = variation(scene, a.field(), b.field());
    // The plan counts four pieces a level; bisection of triangles that are not right
    // isosceles, and conformity, add more. Where the refined scene passes the growth by
    // more than a fifth, the plan is made again for the growth scaled down by the overshoot
    // (once: deterministic, and the second is within a few per cent).
    const std::size_t before = scene.patch_count();
    const double wanted = c.refine.growth * static_cast<double>(before);
    double growth = c.refine.growth;
    RefinePlan plan;
    Refined out{scene, json::object(), "", 0.0};
    std::size_t splits = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
        plan = plan_refinement(scene, varies, growth);
        if (attempt > 0) out.scene = scene;
        splits = plan.marked > 0 ? scenes::refine_patches(out.scene, plan.max_edge, nullptr, c.run.threads) : 0;
        const double added = static_cast<double>(out.scene.patch_count()) - static_cast<double>(before);
        if (added <= 1.2 * wanted) break;
        growth *= wanted / added;
    }
    out.seconds = since(t0);
    const std::size_t after = out.scene.patch_count();
    bool varies_somewhere = false;
    for (const double v : varies) varies_somewhere = varies_somewhere || v > 0.0;
    out.record = {{"growth", c.refine.growth},
                  {"growth_used", growth},
                  {"pilot_steps", options.steps},
                  {"patches_before", before},
                  {"patches_after", after},
                  {"patches_marked", plan.marked},
                  {"patches_planned", plan.planned},
                  {"deepest_level", plan.deepest},
                  {"splits", splits},
                  {"variation_covered", plan.covered},
                  {"seconds", out.seconds}};
    out.decision = plan.marked == 0 && !varies_somewhere
                       ? strprintf("by the solution: a pilot of %ld steps per chain found no patch whose radiance varies "
                                   "beyond its noise; the %zu patches kept",
                                   options.steps, before)
                   : plan.marked == 0
                       ? strprintf("by the solution: a pilot of %ld steps per chain; no cut fits a growth of %g (the least "
                                   "adds 3 patches); the %zu patches kept",
                                   options.steps, growth, before)
                       : strprintf("by the solution: a pilot of %ld steps per chain; %zu of %zu patches cut (up to %d "
                                   "levels, %.0f %% of the area x variation), %zu patches (growth %g)",
                                   options.steps, plan.marked, before, plan.deepest, 100.0 * plan.covered, after,
                                   c.refine.growth);
    return out;
}

RunResult run_scene(const scenes::Scene& scene, const RunConfig& c, const RunHooks& given);

}  // namespace

RunResult run(const scenes::Scene& scene, const RunConfig& c, const RunHooks& hooks) {
    if (!c.refine.on || c.solver.method == "pathtrace") return run_scene(scene, c, hooks);
    Refined refined = refined_by_solution(scene, c);
    RunConfig rest = c;
    rest.seconds_spent += refined.seconds;  // a time budget counts the pilot
    // The map keeps the resolution of the scene as given: the automatic one follows the
    // small patches (visibility/backend.h), and the cuts' pieces would raise it 2-4x
    // for a quarter more patches (on the OBJ asset 528 -> 1,247: twice the time a step).
    // The pieces get fewer pixels each; the image reads them through many rays.
    if (rest.solver.map.resolution <= 0) rest.solver.map.resolution = visibility::default_resolution(scene);
    require_memory(rest, refined.scene);  // at the map's resolution as it will be
    RunResult out = run_scene(refined.scene, rest, hooks);
    out.record["refinement"] = std::move(refined.record);
    out.record["decisions"]["refinement"] =
        refined.decision + (c.solver.map.resolution <= 0 ? strprintf("; the map at the resolution of the scene as given, %d",
                                                                     rest.solver.map.resolution)
                                                         : std::string());
    if (out.record.contains("seconds_total")) out.record["seconds_total"] = out.record["seconds_total"].get<double>() + refined.seconds;
    out.record["phases"].insert(out.record["phases"].begin(),
                                json{{"phase", "refine"}, {"seconds", refined.seconds}, {"threads", c.run.threads}});
    out.refined = std::move(refined.scene);
    return out;
}

namespace {

RunResult run_scene(const scenes::Scene& scene, const RunConfig& c, const RunHooks& given) {
    const auto t_start = Clock::now();
    // Each warning once (a checkpoint on a full disk fails at every interval): its
    // repeats are counted and said at the end.
    OnceEach warnings(given.warn);
    RunHooks hooks = given;
    if (given.warn) hooks.warn = [&warnings](const std::string& line) { warnings(line); };
    const sampling::Team* team = c.run.team && c.run.team->size() > 1 ? c.run.team : nullptr;
    if (team) require_spreadable(c, team->size());
    // The run's identity (the scene's hash: a serial pass over all of it) where a
    // checkpoint is read or written or a team must agree, else none.
    const bool identified = c.resume || team || !c.checkpoint.empty();
    const json identity = identified ? run_identity(c.identity, scene) : json();
    if (c.resume) require_same_run(c.resume_file, c.resume->identity, identity);
    if (team) require_same_everywhere(identity, *team);
    // Each phase's wall seconds and threads, in order (the stats' "phases").
    json phases = json::array();
    auto phase = [&phases](const char* name, double seconds, int threads) {
        phases.push_back({{"phase", name}, {"seconds", seconds}, {"threads", threads}});
    };
    auto t_phase = Clock::now();
    const scenes::RayCaster caster(scene, c.run.threads);
    phase("ray_caster", since(t_phase), c.run.threads);
    // The scene's warnings (the camera's view on a grid of at most 128^2 rays).
    t_phase = Clock::now();
    const SceneSummary summary = summarize(scene, caster, c.run.threads, 128 * 128);
    phase("scene_check", since(t_phase), c.run.threads);
    if (c.solver.method == "pathtrace") {
        warn_about(scene, summary, hooks);
        RunResult traced = path_trace_run(scene, caster, c, rounds_left(c, since(t_start), hooks), t_start);
        phase("path_trace", traced.rounds.seconds_render, c.run.threads);
        traced.record["phases"] = phases;
        return traced;
    }

    // The first shot (point and directional lights) and the diffuse shot, once, before any direction.
    solver::ShotOptions shots = c.shots;
    std::string shot_choice;
    std::tie(shots.diffuse_shot, shot_choice) = decide_diffuse_shot(scene, c.diffuse_shot);
    const solver::Transport transport(scene, shots, c.run, &caster);
    phase("first_shot", transport.shot_stats().seconds, c.run.threads);
    phase("diffuse_shot", transport.shot_stats().diffuse_seconds, c.run.threads);
    // Two independent chains, whose difference estimates the error (render/progressive.h).
    // Spread over a team, each member runs its share of both (TeamChain).
    const int rank = team ? team->rank() : 0, members = team ? team->size() : 1;
    solver::SolverOptions per_chain = c.solver;
    per_chain.steps = chain_steps(c.solver.steps, c.rounds);
    solver::SolverOptions mine = per_chain;
    mine.steps = std::max(1L, steps_of(per_chain.steps, rank, members));
    const auto first_chain = 2 * static_cast<std::uint64_t>(rank);
    // In one process with two threads or more, the chains run side by side and share
    // the threads (the first takes the odd one); a team's members advance their chains
    // in turn, since each advance talks to the team.
    const auto& backends = visibility::backend_infos();
    const bool side_by_side = !team && c.run.threads >= 2 &&
                              std::any_of(backends.begin(), backends.end(), [&](const visibility::BackendInfo& b) {
                                  return b.name == c.solver.visibility && b.side_by_side;
                              });
    sampling::RunOptions run_a = c.run, run_b = c.run;
    if (side_by_side) run_a.threads = (c.run.threads + 1) / 2, run_b.threads = c.run.threads / 2;
    // The chains' solvers (their backends hold vectors the size of the scene), made
    // side by side where they will run so.
    const auto t_setup = Clock::now();
    std::optional<SolverChain> made_a, made_b;
    run_threads(side_by_side ? 2 : 1, [&](int h) {
        for (int k = h; k < 2; k += side_by_side ? 2 : 1) {
            if (k == 0) made_a.emplace(transport, mine, run_a, first_chain);
            else made_b.emplace(transport, mine, run_b, first_chain + 1);
        }
    });
    SolverChain &chain_a = *made_a, &chain_b = *made_b;
    // The scene's warnings once the transport and the solvers have accepted the options
    // (a refused option is the run's one line), before the steps.
    warn_about(scene, summary, hooks);
    std::optional<TeamChain> team_a, team_b;
    if (team) team_a.emplace(chain_a, *team), team_b.emplace(chain_b, *team);
    FieldChain& field_a = team ? static_cast<FieldChain&>(*team_a) : chain_a;
    FieldChain& field_b = team ? static_cast<FieldChain&>(*team_b) : chain_b;
    // What the method converges to on a scene with a known answer (walks truncated at D
    // bounces: a known fraction of it on a homogeneous scene).
    std::optional<double> exact;
    if (scene.exact_radiance) {
        exact = scene.exact_radiance;
        if (scene.homogeneous_albedo) *exact *= chain_a.solver().converged_fraction(*scene.homogeneous_albedo);
    }

    FieldImageOptions image_options;
    image_options.steps = c.solver.steps;
    image_options.gather = c.gather.gather_rays > 0;
    image_options.gather_options = c.gather;
    image_options.auto_correction = c.auto_correction;
    image_options.shading = c.shading;
    image_options.chains_side_by_side = side_by_side;
    RunResult out;
    std::vector<ConvergenceRow>& rows = out.rows;
    double seconds_before = 0.0;  // of a resumed run's solve
    if (c.record_every >= 0) image_options.record_every = c.record_every > 0 ? c.record_every : std::max(2L, c.solver.steps / 100);
    const auto observe = [&](const Snapshot& s) {
        if (c.record_every < 0) return;
        ConvergenceRow row;
        row.steps = s.steps;
        row.seconds = seconds_before + s.seconds;
        if (exact) row.error = s.field->relative_l1_error(scene, *exact);
        row.mean = s.field->mean_radiance(scene);
        if (s.field_estimate >= 0.0) row.estimate = s.field_estimate;
        if (s.image) add_image_columns(row, s, c.reference);
        rows.push_back(row);
    };
    // Going on from a checkpoint; checkpoints and stops between steps.
    if (c.resume) {
        resume_chains(c.resume_file, *c.resume, {&chain_a.solver(), &chain_b.solver()}, per_chain.steps);
        image_options.resume_steps = c.resume->steps_done;
        seconds_before = c.resume->seconds;
        rows = rows_from(c.resume_file, c.resume->rows);
    }
    Pauses pauses(c, hooks, identity, {&chain_a.solver(), &chain_b.solver()}, rows, image_options.resume_steps,
                  seconds_before);
    phase("setup", since(t_setup), c.run.threads);
    image_options.pause = [&pauses](long done) { return pauses(done); };
    // Pauses no shorter than the solver's batches of directions (4 per thread), and
    // longer where steps are quick: every pause waits for both chains (on two threads
    // at 121k patches, pauses every 16 steps cost 3 % of the solve) and refills the
    // pipeline of batches (one batch's light moves while the next one's matrices are
    // computed). The interval follows the clock (up to about a second: a stop request
    // is answered that soon), except where checkpoints fall at step counts, and on a
    // team, whose members must pause at the same steps whatever their clocks say.
    image_options.pause_every = std::max(16L, 4L * c.run.threads);
    if (c.checkpoint_steps <= 0 && !team) image_options.pause_seconds = 1.0;
    // Without checkpoints or a team, a pause only reads the stop request, which the
    // chains side by side read at every step instead, without pausing.
    if (c.checkpoint.empty() && !team && hooks.stop_requested)
        image_options.go_on = [&hooks] { return hooks.stop_requested() == 0; };
    // From here a first stop request ends the solve and makes the image of the steps done.
    if (hooks.stoppable) hooks.stoppable();
    const PinholeCamera camera(scene.camera);
    const RoundOptions rounds = rounds_left(c, since(t_start), hooks);
    std::optional<FieldImage> made_or_none;
    try {
        made_or_none = field_image(scene, caster, camera, field_a, field_b, image_options, rounds, c.run, observe);
    } catch (const Interrupted& e) {
        const int asked = hooks.stop_requested ? hooks.stop_requested() : 0;
        throw RunInterrupted(e.what(), team ? pauses.signal() : asked, pauses.checkpointed());
    }
    FieldImage& made = *made_or_none;
    if (rounds.time_budget > 1e-9)  // else rounds_left has said why already
        warn_if_over(c, scene, made.rounds, c.seconds_spent + since(t_start), hooks);
    require_finite(made.field, scene);
    require_finite(made.image, "the image");
    // Every member's work in the report.
    out.report = combined(chain_a.solver().report(), chain_b.solver().report());
    if (team) {
        out.report.steps = team->sum(out.report.steps);
        out.report.directions = team->sum(out.report.directions);
        out.report.entries_total = static_cast<std::size_t>(team->sum(static_cast<long>(out.report.entries_total)));
        out.report.seconds_visibility = team->sum(out.report.seconds_visibility);
        out.report.seconds_transport = team->sum(out.report.seconds_transport);
        team->finish();
    }
    out.signal = team ? pauses.signal() : (hooks.stop_requested ? hooks.stop_requested() : 0);
    out.checkpointed = pauses.checkpointed();
    // A time budget's or a target's rounds go on as their measurements say: no plan.
    out.planned_steps = c.rounds.time_budget > 0.0 || c.rounds.target_error > 0.0 ? 0 : 2 * per_chain.steps;
    out.steps = made.steps;
    out.mean_radiance = made.field.mean_radiance(scene);
    out.field_estimate = made.field_estimate;
    if (exact) out.error = made.field.relative_l1_error(scene, *exact);
    out.against = compare(c.reference, made.image);
    out.rounds = made.rounds;

    out.image = std::move(made.image);
    out.gather = std::move(made.gather);
    out.field = std::move(made.field);
    phase("solve", out.rounds.seconds_solve, c.run.threads);
    if (out.gather) {
        phase("gather_guides", out.gather->seconds_guides, c.run.threads);
        phase("filter", out.gather->seconds_filter, c.run.threads);
        phase("gather_samples", out.gather->seconds_samples, c.run.threads);
    } else {
        phase("patch_image", out.rounds.seconds_render, c.run.threads);
    }
    FieldRunFacts facts;
    facts.phases = std::move(phases);
    facts.side_by_side = side_by_side;
    facts.coplanar_overlaps = summary.overlaps.pairs;
    facts.members = members;
    facts.seconds_total = since(t_start);
    facts.shot_choice = shot_choice;
    facts.resume_steps = image_options.resume_steps;
    facts.seconds_before = seconds_before;
    facts.exact = exact;
    out.record = field_run_record(scene, c, transport, out, facts);
    return out;
}

}  // namespace

void require_spreadable(const RunConfig& c, int members) {
    const std::string n = std::to_string(members);
    if (c.solver.method == "pathtrace")
        throw RunError("--method pathtrace runs in one process: it is the reference, not spread over " + n + " ranks");
    if (c.rounds.time_budget > 0.0)
        throw RunError("--time-budget on " + n + " ranks: how far the rounds go would depend on the machines' speed; "
                       "give --iterations or --target-error");
    if (!c.checkpoint.empty() || c.resume || !c.resume_file.empty())
        throw RunError(std::string(c.checkpoint.empty() ? "--resume" : "--checkpoint") + " works in one process, not on " +
                       n + " ranks");
    if (2 * static_cast<std::uint64_t>(members) > sampling::streams::kMaxChains)
        throw RunError(n + " ranks: at most " + std::to_string(sampling::streams::kMaxChains / 2) +
                       " (two independent chains each)");
}

Image read_reference(const std::string& path, const scenes::Scene& scene) {
    Image ref;
    try {
        ref = read_exr(path);
    } catch (const std::runtime_error& e) {
        throw scenes::OptionError("reference", e.what());
    }
    if (ref.width != scene.camera.width || ref.height != scene.camera.height)
        throw scenes::OptionError("reference", path + ": " + std::to_string(ref.width) + "x" + std::to_string(ref.height) +
                                                   " pixels, the image is " + std::to_string(scene.camera.width) + "x" +
                                                   std::to_string(scene.camera.height));
    return ref;
}

}  // namespace raybundle::render
