#pragma once
// The solvers' one interface, and the factory that makes them by name, as the
// visibility backends are made (visibility/backend.h).
//
// Methods (004):
//   iteration      stochastic iteration (section 4.4.1) with the constant basis, or
//                  with the piecewise-linear basis (section 5.3; basis "linear")
//   walk           global walks of D directions (4.1)
//   combined       every subsequence of a walk's directions (4.2)
//   bidirectional  combined, each matrix used for w and -w (4.2)
//
// Call order: make_solver(...) once (it checks the options against the scene and
// throws OptionError for what it cannot do); run() for SolverOptions::steps, or
// advance(k) as often as wanted, each going on where the last stopped; both report
// progress through RunOptions::progress ("solve", steps or walks of that call) and
// never print; then field(), averaged() and report(), also between calls and from
// inside the progress callback.
//
// Checkpoints: save() writes what advance() has changed (solver/state.h); restore(),
// on a solver made with the same transport, options and run (a fresh one, before any
// advance()), takes it back, and the solver goes on bit-identically: save after k
// steps, restore, advance(n - k) gives what advance(n) gives. It throws StateError for
// bytes another method, scene or option set wrote.
//
// Chains: RunOptions::chain picks the solver's random streams. Solvers of one seed
// and different chains are independent; the pipeline runs two and compares them to
// estimate the error (render/progressive.h).
#include "sampling/run.h"
#include "sampling/walk_sampler.h"
#include "solver/pipeline.h"
#include "solver/radiance_field.h"
#include "solver/state.h"
#include "solver/transport.h"
#include "visibility/backend.h"
#include "visibility/parallel.h"

#include <nlohmann/json.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace raybundle::solver {

// Everything a method can be told; each method reads the fields that concern it.
struct SolverOptions {
    std::string method = "iteration";
    std::string basis = "constant";  // iteration: constant (per patch) or linear (per vertex)
    long steps = 1000;               // steps of stochastic iteration, or walks
    // Iteration: every geometry matrix serves w and -w (weight 1/2 each). Unbiased, and
    // a step moves light for every patch instead of about half of them: on the
    // homogeneous box the error at equal steps falls about 4x for 10 % more time.
    bool both_ways = true;
    // Iteration, for high albedo (solver/stochastic_iteration.h, docs/stability.md): the
    // ambient control variate and start, and frames: every step moves the light along
    // the three axes of a random orthogonal frame (weight 1/3 each; three times the
    // visibility per step; diffuse scenes) instead of one direction. Unset: decided per
    // scene (decided()): both on where an albedo passes kStableAlbedo, else off.
    std::optional<bool> ambient;
    std::optional<bool> frame;
    int depth = 5;          // walks: directions (bounces) per walk
    bool unbiased = false;  // walks: each walk's last bounce corrects the next one's emission (4.3)
    sampling::SamplerKind sampler = sampling::SamplerKind::random;  // walks: their directions
    // Walks with the vegas and metropolis samplers (solver/walk_source.h): the
    // Metropolis perturbation's extent (delta, in the unit cube of the walk's 2D
    // coordinates), its probability of a large step, and its seed walks per chain (the
    // first walks of the chain's `steps`; 0: kAutoSeedShare of them).
    double mutation_size = 0.1;
    double large_step = 0.3;
    long seed_walks = 0;
    static constexpr double kAutoSeedShare = 0.3;
    std::string visibility = visibility::kDefaultBackend;  // the backend (the linear basis brings its own painter)
    visibility::BackendOptions map;  // its resolution and jitter (make_solver adds the sky when the scene has one)
};

// The visibility a run used.
struct VisibilityUsed {
    std::string backend, details;
    bool exact = false;
    int resolution = 0;
    int threads = 1;  // backends side by side
};
VisibilityUsed describe(visibility::BackendSet& backends);

// What a run did and decided: the common figures, then the method's own.
struct SolverReport {
    std::string method;
    VisibilityUsed visibility;
    long steps = 0;       // steps or walks done
    long directions = 0;  // geometry matrices computed
    // Seconds computing matrices and moving light along them: each step's or walk's own
    // seconds, summed (on several threads, more than the solve's wall time); a GPU's
    // batches (iteration with a backend that takes them): the wall time of the batches
    // less the moving done beside them, so that the two add up to the solve's.
    double seconds_visibility = 0.0, seconds_transport = 0.0;
    std::size_t entries_total = 0;    // geometry-matrix entries over all directions
    std::size_t bytes_per_patch = 0;  // the method's per-patch vectors
    nlohmann::json details = nlohmann::json::object();    // settings and figures of the method
    nlohmann::json decisions = nlohmann::json::object();  // what it decided for this scene, and why
};

// A cache line of its own, like visibility::Backend: the two chains' solvers, made one
// after another, advance side by side and write their counters at every step.
class alignas(64) Solver {
public:
    virtual ~Solver() = default;
    // `steps` more steps (or walks), going on from where the last call stopped: the
    // same seed and chain give the same result however the steps are split into calls.
    virtual void advance(long steps) = 0;
    // The same `steps` as a stream of items that threads share with other solvers'
    // streams (solver/pipeline.h: a run's two chains side by side), on the solver's
    // backends; `shared`: other streams run beside it (a window wide enough for their
    // threads to help). None where the solver cannot: its steps depend on each other
    // beyond the light moved in order (a walk source that adapts, the unbiased
    // correction, the linear basis), or its one backend takes batches (a GPU's
    // submissions); then advance().
    virtual std::optional<StepStream> stream(long steps, bool shared) {
        (void)steps, (void)shared;
        return std::nullopt;
    }
    // SolverOptions::steps of them.
    void run() { advance(planned_); }
    // The current estimate (the mean of the steps or walks so far), made on `threads`
    // threads (0: the solver's own; a chain that shares the threads with another is
    // asked between steps for all of them).
    virtual RadianceField field(int threads = 0) const = 0;
    // How many steps or walks field() averages (burn-in steps left out): the field of
    // the steps between two moments is (n2 field2 - n1 field1) / (n2 - n1).
    virtual long averaged() const = 0;
    virtual SolverReport report() const = 0;
    virtual void save(StateWriter& out) const = 0;
    virtual void restore(StateReader& in) = 0;
    // What the method converges to on a closed homogeneous scene of albedo `albedo`,
    // relative to the exact answer: 1, or 1 - a^(D+1) for walks truncated at D bounces.
    virtual double converged_fraction(double albedo) const {
        (void)albedo;
        return 1.0;
    }

protected:
    explicit Solver(long planned_steps) : planned_(planned_steps) {}

private:
    long planned_;
};

// The counters of a report (steps, directions, seconds, entries), for save()/restore():
// the rest of a report is fixed when the solver is made.
void save_counters(StateWriter& out, const SolverReport& report);
void restore_counters(StateReader& in, SolverReport& report);

// The largest albedo (diffuse plus specular, in any channel) at which stochastic
// iteration with one direction per step keeps a finite variance: a patch's exposure
// to one direction, 4 T in units of its mean, has E[(4 T)^2] = 4/3, so an error the
// chain carries is multiplied by albedo x 4 T per step and its mean square grows once
// albedo^2 4/3 > 1. Over a frame's three axes E[(4 T)^2] = 1.0104: stable to 0.995.
inline constexpr double kStableAlbedo = 0.8660254037844386;  // sqrt(3) / 2

// `options` with `ambient` and `frame` decided for the scene where they are unset: on
// for stochastic iteration with the constant basis when the largest albedo passes
// kStableAlbedo (frames only in a purely diffuse scene), off otherwise.
SolverOptions decided(const SolverOptions& options, const Transport& transport);

// The methods make_solver knows.
std::vector<std::string> method_names();

// Makes the solver of options.method, with its visibility backends (one per thread of
// `run`). The transport (patch constants, first and diffuse shot) must outlive it.
// Throws OptionError naming the option ("method", "basis", "sampler", "depth",
// "unbiased", "both_ways", "visibility", ...) for a combination it cannot run.
std::unique_ptr<Solver> make_solver(const Transport& transport, const SolverOptions& options,
                                    const sampling::RunOptions& run);

}  // namespace raybundle::solver
