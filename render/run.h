#pragma once
// A whole run as one library call: a loaded scene and a configuration in, the image,
// the radiance field and the run's record out. The command line, the tests and the
// benchmarks all call it; the command line only parses, checks memory and writes.
//
//   run(scene, config, hooks):
//     with config.refine on, a pilot solve and the scene refined where its radiance
//     varies (render/adaptive.h; RunResult::refined), the rest on that scene;
//     the scene's warnings (hooks.warn) and its summary (coplanar overlaps, windings);
//     --method pathtrace: the reference path tracer in rounds (no field);
//     else the decisions (the diffuse shot, per scene unless given), the transport
//     (first shot, diffuse shot), two independent chains of the solver (spread over
//     the members of config.run.team where there are several: each runs its share of
//     both), a checkpoint read back (config.resume) or written as the run goes
//     (config.checkpoint), then the image in rounds (render/progressive.h), and the
//     record: every setting, decision and figure (the stats file).
//
// Call order: hooks.stoppable() is called once the run can stop cleanly (from the
// solve on); from then hooks.stop_requested() is asked between steps (a non-zero
// signal number stops the solve, the image is made from the steps done and the result
// is marked interrupted). Progress goes to config.run.progress.
//
// Errors: scenes::OptionError for an option a library refuses, CheckpointError for a
// checkpoint that cannot be read or is another run's, RunError for a run the team
// cannot do together, RunInterrupted where a stop came before there was any image.
#include "render/adaptive.h"
#include "render/checkpoint.h"
#include "render/final_gather.h"
#include "render/image.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/progressive.h"
#include "render/shade.h"
#include "sampling/run.h"
#include "scenes/machine.h"
#include "scenes/scene.h"
#include "scenes/threads.h"
#include "solver/solver.h"
#include "solver/transport.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::render {

// What a run computes from. Every default is here, and nowhere else.
struct RunConfig {
    // The method and its options; solver.method "pathtrace" runs the path tracer.
    solver::SolverOptions solver;
    solver::ShotOptions shots;               // the first shot's and diffuse shot's settings
    std::optional<bool> diffuse_shot;        // unset: on for diffuse scenes with area lights
    sampling::RunOptions run = all_cores();  // seed, threads (default: all cores), progress, team
    GatherOptions gather;                    // gather_rays 0: the patch image instead
    // The correction "auto" (render/progressive.h): with gather.correction 0 and the
    // bias probe on, the rounds choose between reading the field and correcting it.
    // Off: gather.correction as given (0: the field read as the answer).
    bool auto_correction = true;
    // Refinement driven by the solution (render/adaptive.h): a pilot solve of the scene
    // as given, then the patches where the radiance varies most are cut before the solve.
    RefineOptions refine;
    Shading shading = Shading::Smooth;       // the patch image
    PathTraceOptions path;                   // --method pathtrace
    RoundOptions rounds;                     // target error, time budget
    // Seconds the run has taken before run() was called (the scene's reading): a time
    // budget counts them, with the run's own preparation (the shots), and gives the
    // rounds what is left.
    double seconds_spent = 0.0;
    long record_every = -1;                  // convergence rows every so many steps (0: about 100; -1: none)
    // The image is compared with this one (relative L1, MSE), named `reference_file`.
    std::optional<Image> reference;
    std::string reference_file;
    // Checkpoints: written to `checkpoint` every `checkpoint_steps` steps (over both
    // chains) or `checkpoint_seconds`, and when a stop is asked for; `resume`, read
    // before (read_checkpoint), goes on from where it stopped. `identity` is what makes
    // two runs the same run (the options part, checkpoint.h).
    std::string checkpoint;
    long checkpoint_steps = 0;
    double checkpoint_seconds = 60.0;
    std::optional<Checkpoint> resume;
    std::string resume_file;
    nlohmann::json identity = nlohmann::json::object();
    // What this process may hold (render/memory.h): the machine's memory, or its share
    // among the members of a team on it (scenes::memory_share, which the command line
    // gathers from its ranks).
    scenes::MemoryShare memory = scenes::memory_share();

    static sampling::RunOptions all_cores() {
        sampling::RunOptions r;
        r.threads = hardware_threads();
        return r;
    }
};

struct RunHooks {
    std::function<void(const std::string& line)> warn;  // a warning, one line
    std::function<void()> stoppable;                      // the run can stop cleanly from now on
    std::function<int()> stop_requested;                  // 0, or the signal that asks it to stop
    TemporaryTracker temporaries;                         // the checkpoint's temporary file
};

// A row of the convergence CSV: a snapshot of the solve (field columns), or the end
// of a round (the image columns too). Missing values stay empty.
struct ConvergenceRow {
    long steps = 0;
    double seconds = 0.0;
    std::optional<double> error, mean, estimate, image_estimate, image_l1, image_mse, image_block4_l1,
        image_worst_block16;
    long round = 0;
};
void write_convergence_csv(const std::string& path, const std::vector<ConvergenceRow>& rows);


struct RunResult {
    // The scene as solved where the run refined it (RunConfig::refine): the field's
    // patches are its patches. Empty: the scene given.
    std::optional<scenes::Scene> refined;
    const scenes::Scene& scene(const scenes::Scene& given) const { return refined ? *refined : given; }
    Image image;
    std::optional<solver::RadianceField> field;  // none for the path tracer
    std::optional<GatherResult> gather;          // the final gather's AOVs and figures
    solver::SolverReport report;                 // both chains' (and every member's) work
    Rounds rounds;
    long steps = 0;                              // over both chains, this run's and a resumed run's
    double mean_radiance = 0.0;
    double field_estimate = -1.0;                // the field's estimated relative L1 error (render/progressive.h)
    std::optional<double> error;                 // against the scene's exact answer
    std::optional<ImageError> against;             // against config.reference
    std::vector<ConvergenceRow> rows;            // every record_every steps and every round
    nlohmann::json record;                       // the stats: settings, decisions, figures
    int signal = 0;                              // the stop asked for (0: none)
    long planned_steps = 0;                      // over both chains; 0 where the rounds decide (a time
                                                 // budget, a target error)
    long checkpointed = -1;                      // steps per chain of the last checkpoint written (-1: none)
};

// The run stopped before it had an image to show.
struct RunInterrupted : Interrupted {
    RunInterrupted(const std::string& what, int sig, long checkpointed_steps)
        : Interrupted(what), signal(sig), checkpointed(checkpointed_steps) {}
    int signal;
    long checkpointed;  // as RunResult::checkpointed
};

// A run that cannot be done: the members of a team read different scenes or were given
// different options, or there are more of them than independent chains; or it needs
// more memory than the machine has (render/memory.h).
struct RunError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// What a run spread over a team of `members` processes cannot do, refused before any
// work (RunError, the flags named): the path tracer (the reference runs alone), a time
// budget (how far the rounds go would depend on the machines' speed), checkpoints, more
// members than independent chains. run() calls it for a team of more than one.
void require_spreadable(const RunConfig& config, int members);

RunResult run(const scenes::Scene& scene, const RunConfig& config, const RunHooks& hooks = {});

// The reference image of a run (RunConfig::reference), read before any work: throws
// OptionError("reference") naming the file when it cannot be read as an EXR or its size
// is not the scene camera's.
Image read_reference(const std::string& path, const scenes::Scene& scene);

}  // namespace raybundle::render
