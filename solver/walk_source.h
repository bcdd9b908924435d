#pragma once
// Where global walks take their directions (solver/global_walks.h): a family, like the
// visibility backends. A walk of D directions is a point of the unit cube [0, 1)^(2D),
// direction d from coordinates 2d and 2d + 1 through sampling::uniform_sphere(). The
// source proposes the point of the next walk, GlobalWalks computes the walk there (its
// D geometry matrices and its estimate of every patch's radiance), and the source
// accepts it: adds to the running sum what the walk is worth. The field is
// scale x sum / count (mean()).
//
//   uniform     random, halton, sobol (walk_source_uniform.cpp): the points of
//               sampling::WalkSampler, each walk weighs 1.
//   vegas       (004 section 7) separable tables learnt from the walks' importance
//               (walk_source_vegas.cpp); a walk weighs 1 / p(z) (eq. 33).
//   metropolis  (004 section 8) chains of walks in proportion to their importance
//               (walk_source_metropolis.cpp); each step adds the expected value of
//               both walks, the field is scaled by the estimated exposure.
//
// The importance of a walk is the luminance it adds to the image (solver/importance.h);
// GlobalWalks computes it only for a source that adapts().
//
// Call order: make_walk_source() once. Then for each walk: propose(), the walk
// evaluated at the proposed point, accept() with its estimate and importance. A source
// that does not adapt has its walks side by side (solver/pipeline.h): propose() of a
// later walk may then run on one thread while accept() of an earlier one runs on
// another (each in walk order), so the two must share no state.
// save()/restore() between walks (a restored source goes on bit-identically);
// report() and mean() at any time.
#include "solver/solver.h"
#include "solver/state.h"

#include <memory>
#include <vector>

namespace raybundle::solver {

using scenes::Rgb;

// The mean a source's walks make: scale x sum / count.
struct WalkMean {
    const std::vector<Rgb>& sum;
    double scale;
    long count;
};

class WalkSource {
public:
    virtual ~WalkSource() = default;
    // Whether accept() needs the walk's importance (otherwise it gets 0).
    virtual bool adapts() const = 0;
    // The point of the next walk, 2 depth coordinates in [0, 1); `walk`: the walks
    // done before it.
    virtual void propose(long walk, double* point) = 0;
    // The walk at the last proposed point: its estimate per patch (the source may
    // swap the vector's contents with one of its own) and its importance. Adds what
    // the walk is worth to `sum`.
    virtual void accept(std::vector<Rgb>& estimate, double importance, std::vector<Rgb>& sum) = 0;
    // The field of the walks so far, given GlobalWalks' sum and walk count.
    virtual WalkMean mean(const std::vector<Rgb>& sum, long walks) const { return {sum, 1.0, walks}; }
    // Per-patch vectors the source keeps (for the report's bytes per patch).
    virtual std::size_t vectors() const { return 0; }
    virtual void save(StateWriter&) const {}
    virtual void restore(StateReader&) {}
    // Adds the source's settings and figures to the report's details.
    virtual void report(SolverReport&) const {}
};

// The source of options.sampler for walks of options.depth over `patches` patches.
// Throws OptionError("sampler") for a sampler it does not know, listing the known.
std::unique_ptr<WalkSource> make_walk_source(const SolverOptions& options, const sampling::RunOptions& run,
                                             std::size_t patches);

// The members of the family, one per file.
std::unique_ptr<WalkSource> make_uniform_source(const SolverOptions& options, const sampling::RunOptions& run);
std::unique_ptr<WalkSource> make_vegas_source(const SolverOptions& options, const sampling::RunOptions& run);
std::unique_ptr<WalkSource> make_metropolis_source(const SolverOptions& options, const sampling::RunOptions& run,
                                                   std::size_t patches);

}  // namespace raybundle::solver
