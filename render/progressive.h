#pragma once
// The run's image, made in rounds, with its error estimated as it goes; the budget
// chosen for a target error or a time.
//
// Two independent halves. The solver runs as two chains (RunOptions::chain 0 and 1,
// each a FieldChain: apps/ wraps solver::Solver), and half h of the image is rendered
// from chain h's field alone, with random streams of its own. From the field to the
// pixel everything is linear, in the field and in the samples (the final gather, the
// guided and cross-bilateral filters for a fixed guide, the patch image), so the mean
// of the two halves is what one run of the whole budget gives (two chains of N/2 steps
// for one of N), and their difference measures its noise: with independent errors
// e_A, e_B of the same symmetric distribution, e_A - e_B is distributed as e_A + e_B,
// so E |(A + B)/2 - truth| = E |A - B| / 2 in every pixel and channel, and
//
//   estimated relative L1 error = sum |A - B| / (2 sum |(A + B) / 2|)
//
// over pixels and channels, the measure of render/metrics.h. That is the noise.
//
// The bias. The final gather's halves also come with an image of their error (with
// the bias probe on, or the correction; else the estimate is the halves' rule alone)
// (GatherResult::bias: r = albedo (filtered E - E - D), D the bias probe's estimate of
// the field's error in E): the image's error is r plus noise that is independent from
// pixel to pixel (albedo (E + D - E*) and the direct light's), so over a block of 8x8
// pixels the mean of r is the image's error there: the filter's and the field's,
// bias and the field's own noise alike, as this image reads them. With m that mean
// (over both halves) and v the spread of r over the block (pooled with its eight
// neighbours': r's noise is heavy-tailed), beta = sqrt(max(0, m^2 -
// v / n)) is the block's error less r's own noise; with sigma the spread of the
// halves' half-difference (a - b) / 2 over the block about its mean (the pixels' noise
// about what the block shares; its mean absolute deviation, over sqrt(2 / pi), which a
// few noisy pixels at a light's edge do not inflate), a pixel's expected error is that
// of a normal error of mean beta and deviation sigma:
//
//   E |N(beta, sigma^2)| = sigma sqrt(2 / pi) exp(-beta^2 / (2 sigma^2)) + beta erf(beta / (sigma sqrt 2)).
//
// Its sum over blocks and channels, over sum |mean - beta| (the truth's, as far as it is
// known; beta with the sign of m), is the probed estimate, and the run's estimate where
// there are bias images. It measures the field's noise as realised in this image,
// where the halves' rule has only its expectation: the two differ most where that noise
// is a few large patterns (docs/final-image.md section 14). ErrorEstimate has both, and
// the probed error's part that is beta ("bias"; the field's noise is in it too, and
// falls as the rounds go on, the bias does not). A block's mean sees what does not
// cancel within it: the filter's blur across an edge inside a block (too bright on one
// side, too dark on the other) is missed, and so are pixels whose guide sample met
// nothing while their further samples meet a surface (a silhouette against the sky). Still not in it: the visibility maps' resolution where the field is read
// directly (the patch image), the diffuse shot's quadrature, the shadow ratio's bias in
// penumbrae, the glossy rays' field readings, and walks truncated at D bounces in the
// patch image. The edge-avoiding A-Trous filter weighs by colour, is not linear, and
// makes the estimate approximate.
//
// Rounds. Round k has a scale r_k: its share of the budget (the camera samples,
// emission samples and gather rays of the options, and as many steps times the
// shape's share, below), halved between the halves (each at least one). It advances
// both chains by their steps, then renders one pass of each half. A pass reads the
// field of its chain's steps since the chain's previous pass (the mean between the
// two moments, from Solver::averaged), and the passes are averaged with weights r_k,
// so that with steps in proportion to r_k the field part of the image is the gather
// of each chain's mean over all its steps: no step counts less for having come early
// (rounds before the share changes weigh their steps off, by up to 8 times: unbiased
// all the same). A pass with camera samples over the pixel keeps two at least. Pass
// p = 2k + h draws from
// its own streams. The rounds:
//   - no target and no time budget: one round of scale 1, the budget as given;
//   - target_error E: a first round of scale 1/4, then each round sized by an error
//     model (below) calibrated to the estimate: the scale that reaches E with 5 % to
//     spare, from an eighth to 8 times the scale so far; until the estimate is at
//     most E, 1024 times the options' budget is spent, or in two rounds in a row the
//     probed error's bias part is E or more and fell by less than a tenth since the
//     budget was half what it is (a bias: more rounds do not lower it;
//     GatherOptions::correction does);
//   - time_budget S (what is left of it once the scene is prepared, render/run.h):
//     rounds sized by the seconds per unit of scale so far to fill S,
//     until a round worth at least an eighth of the scale so far no longer fits; the
//     first round always runs, its steps cut to what fits in an eighth of S once a
//     quarter of them is timed;
//   - both: whichever stops first.
// The correction, "auto" (FieldImageOptions::auto_correction; the run's default). With
// the bias probe on, a pass also comes as the correction at the probe's rate P would
// make it (GatherResult::corrected: free of the field's bias in the gather rays'
// readings, noisier), so every round has two images: U, the field read as the answer,
// and C, corrected. The run shows C when the field's part of the bias the halves share
// (U's ErrorEstimate::shared less C's, the filter's, in quadrature) stands above the
// noise the probe's corrections add (C's halves' rule less U's, in quadrature), else U
// (a root mean square against L1 measures: a rough rule); and after each round, while
// the rounds read the field, it predicts the final error of going on as now against
// going on with the correction at q (1/8, 1/4, 1/2, 1: paths instead of the probe, at
// their cost) from what it has measured (choose_correction), and switches to the best
// q for good where that is better or costs at most a quarter more: the image is then C,
// the probed rounds before counted with their corrections. Until it switches, the
// rounds of a time budget at most double the budget so far. As the budget grows, the halves' noise falls
// and the field's bias does not, so the choice goes to C: the image converges to the
// scene's light up to the filter's blur, whatever the field (docs/final-image.md
// section 15). The AOVs other than the image (indirect, filtered, bias) stay those of
// the passes as made: U's while the rounds probe.
//
// With a target or a time budget the first two rounds also measure how much of the
// estimate is the field's noise (a probe: half A's samples again, on chain B's field)
// and set the share of the steps for the rounds after them: the solve gets more where
// the field's noise dominates (light through a door), less where the samples' does
// (render/progressive.cpp, Shape). The same seed gives the same image, for any thread
// count, except with a time budget: how far its rounds go depends on the machine.
#include "render/camera.h"
#include "render/final_gather.h"
#include "render/image.h"
#include "render/path_tracer.h"
#include "render/shade.h"
#include "sampling/run.h"
#include "scenes/ray_caster.h"
#include "solver/pipeline.h"
#include "solver/radiance_field.h"

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::render {

// What the image needs of a solver: one independent chain of it.
class FieldChain {
public:
    virtual ~FieldChain() = default;
    // `steps` more steps, going on from the last call; progress ("solve", done of steps).
    virtual void advance(long steps, const sampling::ProgressCallback& progress) = 0;
    // The same steps as a stream that threads share with the other chain's
    // (solver/pipeline.h), its progress to `progress`; none where the chain cannot
    // (then advance()).
    virtual std::optional<solver::StepStream> stream(long steps, const sampling::ProgressCallback& progress) {
        (void)steps, (void)progress;
        return std::nullopt;
    }
    // The mean over the steps so far (made on `threads` threads, 0: the chain's own),
    // and how many steps it averages.
    virtual solver::RadianceField field(int threads = 0) const = 0;
    virtual long averaged() const = 0;
};

struct RoundOptions {
    double target_error = 0.0;  // stop once the estimate is at most this (0: none)
    double time_budget = 0.0;   // seconds for the rounds (0: none)
};

// One round's record.
// An image's estimated relative L1 error (see above): the total, the halves' rule
// (noise), the probed error and its bias part (both 0 without bias images; negative:
// none).
struct ErrorEstimate {
    double total = -1.0, noise = -1.0, probed = -1.0, bias = -1.0;
    // The bias both halves share, as a root mean square over the image relative to the
    // truth's mean |value|: from the products of the halves' block means of r, whose
    // expectation is the square of the error they have in common (the chains' noise is
    // independent between the halves, the field's bias is not), less twice the sum's
    // standard error: what stands out of the noise. 0 without bias images.
    double shared = -1.0;
};

struct CorrectionPlan {
    double q = 0.0;           // 0: go on reading the field
    double predicted = 0.0;   // its predicted final error
    double reading = 0.0;     // the predicted final error of reading the field
};

struct Round {
    double scale = 0.0;     // its share of the budget (camera samples, gather rays)
    double correction = 0.0;  // the correction it ran with (GatherOptions::correction)
    bool corrected = false; // the image after it is the corrected one (C)
    double corrected_noise = -1.0;  // C's halves' rule while the rounds probe (negative: none)
    CorrectionPlan plan;    // the correction "auto"'s prediction after it (q 0 and all 0: none)
    double steps = 0.0;     // its share of the options' steps
    double seconds = 0.0;   // since the rounds began, at its end
    double estimate = -1.0; // the image's estimated relative L1 error after it
    ErrorEstimate parts;    // the same with its parts
};

struct Rounds {
    std::vector<Round> rounds;
    double scale = 0.0;         // the budget used, in units of the options' budget
    double estimate = -1.0;     // the final image's estimated relative L1 error
    ErrorEstimate parts;        // the same with its parts (bias 0 where there is no bias image)
    std::string stopped;        // why the rounds stopped
    bool interrupted = false;   // by FieldImageOptions::pause, before the rounds were done
    // Wall time of the chains' steps, of the passes, and of the probes.
    double seconds_solve = 0.0, seconds_render = 0.0, seconds_probe = 0.0;
    double steps_share = 1.0;   // steps per unit of scale of the last rounds, relative to the options'
    double field_share = -1.0;  // the field's part of the latest probed round's estimate (negative: not probed)
    // The correction "auto" (else: correction 0, not corrected, choice empty): the
    // correction of the last rounds, whether the image is the corrected one, and why.
    double correction = 0.0;
    bool corrected = false;
    std::string correction_choice;
};

// What choose_correction weighs (relative L1 errors, as the estimates give them).
struct CorrectionInputs {
    double probe = 0.0;            // P, the bias probe's rate
    double noise = 0.0;            // U's halves' rule: its noise
    double bias = 0.0;             // U's shared bias (ErrorEstimate::shared): the field's and the filter's
    double corrected_noise = 0.0;  // C's halves' rule
    double corrected_bias = 0.0;   // C's shared bias: the filter's
    double scale = 0.0;            // the budget so far
    double more = 0.0;             // the budget still to come at the probe's cost (0: none)
    double probe_cost = 0.0;       // the probe's share of that cost
    // How much more predicted error the correction may cost than reading the field: the
    // price of removing a bias too small for the probe to see yet.
    double tolerance = 0.25;
};

// The correction for the rounds to come: 0 (read the field; the probe goes on) or the
// q of {1/8, 1/4, 1/2, 1} (>= P) with the least predicted final error, where, with
// R = scale, x = more at the probe's cost (more / (1 + probe_cost (q / P - 1)) with the
// correction), n = noise, c^2 = corrected_noise^2 - n^2 (the probe's corrections' own
// noise), b = bias and f = corrected_bias:
//
//   reading the field:  b^2 + n^2 R / (R + x)
//   correcting at q:    f^2 + n^2 R / (R + x) + c^2 R (R + x P / q) / (R + x)^2
//
// (each term's noise falls as its share of the budget grows; the probe's corrections
// so far count in the corrected image with their own, P's, noise).
CorrectionPlan choose_correction(const CorrectionInputs& in);

// What the caller sees as the run goes: after every `record_every` steps of the solve
// (the field of both chains so far; image empty), and after every round (the image so
// far). Negative estimates: none yet.
struct Snapshot {
    long steps = 0;               // over both chains
    double seconds = 0.0;         // since the rounds began
    const solver::RadianceField* field = nullptr;  // the mean of both chains (gather runs)
    double field_estimate = -1.0;  // its relative L1 error over patches, estimated likewise
    const Image* image = nullptr;  // after a round
    double image_estimate = -1.0;
    long round = 0;                // 1, 2, ... after a round; 0 in the solve
};
using Observer = std::function<void(const Snapshot&)>;

// The radiance-field pipeline: both chains (a = chain 0, b = chain 1, fresh), the
// final gather (gather.gather_rays > 0) or the patch image (`shading`).
struct FieldImageOptions {
    long steps = 1000;       // per round of scale 1, over both chains
    bool gather = true;      // the final gather, else the patch image
    GatherOptions gather_options;  // gather_rays and spp per round of scale 1, over both halves
    Shading shading = Shading::Smooth;
    long record_every = 0;   // steps (over both chains) between solve snapshots (0: none)
    // Interruption and checkpoints (apps/): with `pause`, the solve stops after every
    // `pause_every` steps of each chain (both chains at one count) and calls pause(done),
    // `done` the steps of each chain in the round so far; false stops the solve there:
    // the round's image is made from the steps done, and the rounds end ("interrupted").
    // Where no step of the round is averaged yet (the burn-in), there is no image to
    // make: the first round throws Interrupted, a later one ends the rounds without it.
    std::function<bool(long done)> pause;
    long pause_every = 16;
    // With pause_seconds > 0, the steps between pauses grow (from pause_every) to what
    // takes about half of it where an interval took less (at least doubling), and halve
    // (down to pause_every) while one takes longer, and a rest shorter than half the
    // interval joins the interval before it: a pause waits for the last steps of both
    // chains under way and refills the solver's pipeline, so they should be rare, and
    // a stop request is still answered within about pause_seconds where steps are. The result
    // does not depend on where the pauses fall. Off on a team: its members must pause
    // at the same steps.
    double pause_seconds = 0.0;
    // Where `pause` only asks whether to stop (no checkpoint, no team), go_on() asks
    // the same without a pause: the chains side by side then run to the next snapshot
    // or the round's end in one interval, ask go_on() before each step any of them
    // begins (the interval's first too: a stop that came during a round's image begins
    // no step of the next), and stop together at the first step it says no to; pause(done) is
    // called at the interval's end as above. (A pause waits for the last steps under
    // way: every thread but one idles for up to a step.) The chains one after the
    // other, or unable to share threads, pause as above.
    std::function<bool()> go_on;
    // A solve going on from a checkpoint: the chains, restored, have each done this many
    // steps of the first round (before any image).
    long resume_steps = 0;
    // The two chains advance at the same time, each on a thread of its own (their
    // solvers share nothing but the const Transport, and each chain's result is a
    // function of its own steps alone). Off where the chains talk to a team.
    bool chains_side_by_side = false;
    // The correction chosen by the rounds from the bias probe (see above): with
    // gather_options.correction 0 and bias_probe > 0.
    bool auto_correction = false;
};

// A run stopped before it had an image to show.
struct Interrupted : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct FieldImage {
    Image image;
    solver::RadianceField field;  // the mean of both chains
    long steps = 0;               // over both chains
    double field_estimate = -1.0;
    // The final gather's AOVs (the weighted mean of all passes; normal, depth and
    // position from the first) and its rays and seconds summed over the passes.
    std::optional<GatherResult> gather;
    Rounds rounds;
};

// The steps each chain's first advance() gets (for SolverOptions::steps, which sizes
// the burn-in).
long chain_steps(long steps, const RoundOptions& rounds);

FieldImage field_image(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                       FieldChain& a, FieldChain& b, const FieldImageOptions& options, const RoundOptions& rounds,
                       const sampling::RunOptions& run, const Observer& observe = {});

// The reference path tracer in rounds: options.spp paths per pixel per round of scale
// 1, over both halves.
struct TracedImage {
    PathTraceResult traced;  // the image; paths, rays and seconds summed over the passes
    Rounds rounds;
};
TracedImage traced_image(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                         const PathTraceOptions& options, const RoundOptions& rounds, const sampling::RunOptions& run,
                         const Observer& observe = {});

// sum |a - b| / (2 sum |(a + b) / 2|) over pixels and channels: the estimated
// relative L1 error of the mean of two independent halves (see above); 0 for images
// that are 0 everywhere.
double estimated_relative_l1(const Image& a, const Image& b);

// The estimate with the halves' bias images bias_a and bias_b (see above; both empty:
// no bias, total = noise) over blocks of `block` pixels. Throws std::invalid_argument
// for sizes that differ or a block below 2.
ErrorEstimate estimate_error(const Image& a, const Image& b, const Image& bias_a, const Image& bias_b, int block = 8);

}  // namespace raybundle::render
