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
// High albedo (docs/stability.md). An error the chain carries in a patch's irradiance
// comes back next step multiplied by its albedo times 4 T_i(w), T_i its exposure to
// the direction (mean 1/4); E[(4 T)^2] = 4/3 for one direction, so above an albedo of
// sqrt(3)/2 (kStableAlbedo) the error's mean square grows from step to step: the mean
// still converges, but through rare excursions of the whole scene's light (at 0.99
// the box's mean went to -1.2 and back within 100 steps). Two remedies, chosen by
// default above kStableAlbedo (solver.h, decided()):
//   - frames (options.frame): each step moves the light along the three axes of a
//     random orthogonal frame, weight 1/3 each (unbiased: each axis is uniform). A
//     patch's exposure over the three scatters far less: E[(4 T)^2] = 1.0104, stable
//     to an albedo of 0.995. Three times the visibility per step. Diffuse scenes
//     (glossy patches reflect the light of one arrival direction).
//   - the ambient control variate and start, below: it takes the exposure's scatter
//     out of the light's mean level, which frames alone leave swinging.
//
// The ambient control variate (options.ambient).
// One direction exposes patch i to a cosine share T_i(w) of its incoming light
// (Transport::receiving_share), whose mean over directions is exactly 1/4 but which
// scatters between 0 and 1/2: in a closed scene of uniform radiance c the estimate is
// c T_i(w) where it should be c / 4, and high albedo feeds that error back for
// ~1/(1 - albedo) steps. So the estimate of diffuse patch i is
//
//   I_i = s_i sum_j A_ij(w) (L_j - c_i)  +  c_i T_i f_i  +  c_i (1/4 - T_i) g_i:
//
// the light's departure from a constant c_i moved by the geometry matrix, plus the
// constant's share, c_i times what of the exposure T_i saw light (f_i: the part of the
// patch's own entries that came from a surface or the sky rather than the void), plus
// a term of mean zero (E[1/4 - T_i] = 0) that takes T_i's scatter out. s_i = T_i f_i /
// sum_j A_ij(w) scales the departure from the pixels' exposure to the exact one (1 with
// an exact backend; a pixel backend gives a patch seen edge-on one pixel of far more
// than its projected area). c_i is the patch's mean incoming radiance over a window of
// steps before (4 x their mean I; windows of 16, 32, 64, ... steps, the last one
// completed: a mean over few steps would feed its noise back, one over all steps would
// remember the start; the ambient radiance before the first; windows begin anew when
// the burn-in ends, from the mean of its last steps); g_i is the mean of f_i over all
// steps before (weighted by T). Neither depends on w. A closed box of one albedo per
// channel is then exact in every step with a backend that pairs every pixel (the
// centre-sorted painter on a convex box; the exact painter leaves a pixel now and then,
// docs/stability.md). f_i needs the void's entries: options.map.sky says the backend
// emits them (make_solver asks for them when the backend can); without them f_i = (what
// the entries covered) / T_i, s_i = 1, and only the third term is added.
//
// Bias: none from the third term, none with an exact backend. With a pixel backend,
// s_i is a ratio of the pixels' counts, whose bias falls with the pixels per patch.
// The chain also starts from the ambient radiance (progressive radiosity's ambient
// term: the mean emission over 1 - the mean albedo, per channel), not from no light,
// which high albedo would take ~1/(1 - albedo) steps to fill in.
//
// Options read: steps, both_ways, ambient, frame (unset: decided()). Call order: see
// solver.h.
#include "solver/solver.h"
#include "visibility/parallel.h"

#include "sampling/directions.h"

#include <algorithm>
#include <array>
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
    // the scene has point or directional lights).
    StochasticIteration(const Transport& transport, visibility::Backend& backend, const SolverOptions& options,
                        const sampling::RunOptions& run);
    StochasticIteration(const scenes::Scene& scene, visibility::Backend& backend, const SolverOptions& options,
                        const sampling::RunOptions& run);

    void advance(long steps) override;
    std::optional<StepStream> stream(long steps, bool shared) override;
    RadianceField field(int threads = 0) const override;
    long averaged() const override { return std::max(0L, steps_ - burn_in_); }
    SolverReport report() const override { return report_; }
    void save(StateWriter& out) const override;
    void restore(StateReader& in) override;

private:
    void init(const SolverOptions& options);  // the options as given, before decided()
    // One step along `count` directions (1, or a frame's 3) with their matrices.
    void step(const scenes::Vec3* directions, const visibility::GeometryMatrix* matrices, int count);
    // Ambient: c_i from the window's mean (take_mean), and a new window begun.
    void close_window(bool take_mean);

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
    // Ambient: c_i, and the I of the window of steps under way summed; T f and T summed
    // from a light pseudo-step of a fully lit patch (g_i); one step's exposure
    // (Transport::exposure).
    std::vector<scenes::Rgb> c_, window_sum_;
    long window_steps_ = 0, window_size_ = 16;
    std::vector<double> covered_sum_, exposed_sum_, lit_, seen_;
    bool voids_ = false;  // the matrices carry the void's entries (options.map.sky)
    scenes::Vec3 previous_ = scenes::Vec3::Zero();
    sampling::RandomDirections directions_;
    sampling::Rng jitter_;
    long steps_ = 0;
    // A step under way (solver/pipeline.h): its directions (1, or a frame's 3), jitters
    // and matrices, and the seconds they took; a cache line of its own, since threads
    // fill neighbouring slots at once.
    struct alignas(64) Slot {
        std::array<scenes::Vec3, 3> w;
        std::array<Eigen::Vector2d, 3> jitter;
        std::array<visibility::GeometryMatrix, 3> matrices;
        double seconds = 0.0;
    };
    std::vector<Slot> slots_;
    std::vector<visibility::GeometryMatrix> matrices_, next_matrices_;  // batches of one backend (a GPU's)
    SolverReport report_;
};

}  // namespace raybundle::solver
