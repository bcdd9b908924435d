#pragma once
// Galerkin piecewise-constant stochastic iteration (004 section 4.4.1):
//
//   I_m = A(w_m) (Le(w_m) + 4 pi F(w_{m-1}, w_m) I_{m-1}),
//
// with independent uniform random directions w_m on the sphere. I_i is the
// cosine-weighted incoming radiance of patch i averaged over its area; the image
// estimate of step m is Le + 4 pi F(w_m, eye) I_m, and the result is the average
// over the M steps.
//
// Skip what the scene does not need: a purely diffuse scene accumulates I and
// shades once at the end (L = Le + 4 albedo <I>); only a scene with glossy materials
// evaluates the view-dependent radiance towards the eye in every step.
//
// Options read: steps, both_ways. Call order: see solver.h.
#include "solver/solver.h"
#include "visibility/parallel.h"

#include "sampling/directions.h"

#include <algorithm>
#include <memory>
#include <vector>

namespace raybundle::solver {

class StochasticIteration final : public Solver {
public:
    // The transport and the backends must outlive the solver. With several backends the
    // visibility of a batch of directions is computed side by side, then the steps run
    // in order (bit-identical for any count).
    StochasticIteration(const Transport& transport, visibility::BackendSet& backends, const SolverOptions& options,
                        const sampling::RunOptions& run);
    StochasticIteration(const Transport& transport, std::unique_ptr<visibility::BackendSet> backends,
                        const SolverOptions& options, const sampling::RunOptions& run);
    // One backend; and the same with a transport of its own (the first shot computed if
    // the scene has point lights).
    StochasticIteration(const Transport& transport, visibility::Backend& backend, const SolverOptions& options,
                        const sampling::RunOptions& run);
    StochasticIteration(const scenes::Scene& scene, visibility::Backend& backend, const SolverOptions& options,
                        const sampling::RunOptions& run);

    void advance(long steps) override;
    RadianceField field() const override;
    long averaged() const override { return std::max(0L, steps_ - burn_in_); }
    SolverReport report() const override { return report_; }

private:
    void init();
    void step(const scenes::Vec3& direction, const visibility::GeometryMatrix& matrix);

    std::unique_ptr<Transport> own_;
    const Transport& transport_;
    std::unique_ptr<visibility::BackendSet> own_set_;
    visibility::BackendSet& backends_;
    SolverOptions options_;
    sampling::RunOptions run_;
    bool glossy_;
    std::vector<scenes::Vec3> to_eye_;             // glossy path only
    std::vector<scenes::Rgb> irradiance_, next_, outgoing_;
    long burn_in_ = 0;                             // steps left out of sum_
    std::vector<scenes::Rgb> sum_;                 // sum of I (diffuse) or of 4 pi F(w, eye) I (glossy)
    scenes::Vec3 previous_ = scenes::Vec3::Zero();
    sampling::RandomDirections directions_;
    sampling::Rng jitter_;
    long steps_ = 0;
    std::vector<visibility::GeometryMatrix> matrices_;  // one batch
    SolverReport report_;
};

}  // namespace raybundle::solver
