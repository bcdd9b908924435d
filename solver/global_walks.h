#pragma once
// Global walks of D directions (004 sections 4.1-4.3).
//
// A walk draws D global directions w_1..w_D (one point of a 2D-dimensional random or
// quasi-random sequence, sampling/walk_sampler.h), computes A(w_t) once for each, and
// adds its estimate of the radiance of every patch; the result is the mean over the
// walks. Three ways to use the D geometry matrices:
//
//   walk           (4.1) the plain walk: I <- A(w_t) (Le + 4 pi F I), t = 1..D. One
//                  estimate of each bounce 1..D per walk. One vector per patch.
//   combined       (4.2) every increasing subsequence of the walk's directions is a
//                  sample of a path: C(D, b+1) samples of the b-bounce irradiance per
//                  walk. The per-patch table Z[b][t] (bounce b, last direction w_t)
//                  has D(D+1)/2 entries (Table 1).
//   bidirectional  (4.2) combined, and every matrix serves w and -w (each patch
//                  receives along the one it faces): 2^(b+1) C(D, b+1) samples.
//
// Truncated at D bounces, the walks converge to Le + T Le + ... + T^D Le: on the
// homogeneous box (albedo a, exact radiance L) to L (1 - a^(D+1)). With `unbiased`
// (4.3) the previous walk's estimate of its D-th bounce, T^D (Le + C), is added to
// the emission C of the next walk's transfers, so that walk m estimates bounces up to
// (m+1) D and the average converges to the full solution; only the first walks miss
// their highest bounces (an energy defect that fades as 1/M). The correction needs
// consecutive walks to be independent: random directions only (QMC walks are
// refused, as for stochastic iteration; consecutive Sobol points biased the
// homogeneous box by up to 17x).
//
// What is stored (skip what a scene does not need): in a purely diffuse scene the
// combined table collapses to one running sum per bounce (D vectors instead of
// D(D+1)/2: 4 pi F does not depend on the direction the light arrived from); glossy
// scenes keep the whole table, each entry with the direction it arrived along, and
// evaluate the radiance towards the eye per walk.
//
// Importance sampling for the image (004 sections 7-8; sampler vegas or metropolis):
// every walk's estimate X(z) is a vector over patches, and its importance
// I(z) = sum_p Y(w_p X_p(z)) is the luminance it adds to the image
// (solver/importance.h).
//
//   vegas       the walk's point is drawn from the separable tables of
//               sampling/adaptive.h (an 8 x 8 table per direction), its estimate is
//               X(z) / p(z) (eq. 33, unbiased for any tables), and the tables are
//               refined from the importance after every phase of 64 walks. The
//               tables' floor keeps p > 0 where the camera sees nothing, so that the
//               light of unseen patches is still estimated.
//   metropolis  (eq. 37-41) 4 chains per solver chain, taking steps in turn (a fixed
//               count: the result does not depend on the threads). The first
//               `seed_walks` walks of the chain's budget (default 30 % of them; more while
//               none brings light to the image) are uniform seed walks: each chain's
//               first walk is one of them, picked in proportion to its importance
//               (8.1.2: the chains start in the stationary distribution; one weighted
//               reservoir per chain, so that no seed is evaluated twice). The
//               importance gets a floor f, 1 % of the seeds' mean (the light of walks
//               the camera does not see keeps a chance). Then every step either
//               perturbs the chain's walk (sampling::Mutation, delta = mutation_size;
//               accepted with a = min(1, I(z') / I(z))) or, with probability
//               large_step, draws a new walk from a density p learnt from the chains
//               (sampling/mixture.h: a mixture of one-direction components, since light
//               through an opening needs one of the walk's directions in its cone;
//               accepted with a = min(1, I(z') p(z) / (I(z) p(z')))). The next 20 % of
//               the steps after the seeds teach the density (refreshed after 16, 20,
//               25, ... of them and at the last) and stay out of the image (none
//               with large_step 0); then it is fixed, so that
//               the chains are plain Metropolis-Hastings (adapting all along biased the
//               homogeneous box by 3 % at 1,200 walks). Every other step adds the
//               expected value of both walks (8.2): b (a X(z') / I(z') + (1 - a) X(z) / I(z)),
//               the field is their mean. The exposure b (8.1.3), the integral of the
//               importance, comes from every independent walk: the seeds (uniform) and
//               the large steps (from p), each density's sum of I / p weighed by a trust
//               fixed in advance (sampling::MixtureEstimate): far less heavy-tailed than
//               the uniform walks' mean, and unbiased. Until the first image step the
//               field is the seeds' mean (a run of random walks). averaged() counts
//               every walk, seeds included, so that it grows with the run as the
//               pipeline's rounds need. Consistent, not unbiased: b is estimated, and
//               004 section 8.4 bounds the start-up bias
//               (tests/solver/test_importance_sampling.cpp).
//
// Options read: steps (walks), depth, unbiased, sampler, mutation_size, large_step,
// seed_walks. Call order: see solver.h.
#include "sampling/adaptive.h"
#include "sampling/mixture.h"
#include "sampling/walk_sampler.h"
#include "solver/importance.h"
#include "solver/solver.h"
#include "visibility/parallel.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace raybundle::solver {

enum class WalkMethod { walk, combined, bidirectional };

const char* walk_method_name(WalkMethod m);

class GlobalWalks final : public Solver {
public:
    // The transport (patch constants, first shot) and the backends must outlive the
    // solver. With several backends the D matrices of a walk are computed side by side
    // (bit-identical results for any count). Throws OptionError for a depth the sampler
    // cannot do or --unbiased with a QMC sampler.
    GlobalWalks(const Transport& transport, visibility::BackendSet& backends, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);
    GlobalWalks(const Transport& transport, visibility::Backend& backend, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);
    GlobalWalks(const Transport& transport, std::unique_ptr<visibility::BackendSet> backends, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);

    void advance(long walks) override;
    RadianceField field() const override;
    long averaged() const override { return walks_done_; }
    SolverReport report() const override;
    void save(StateWriter& out) const override;
    void restore(StateReader& in) override;
    // (The diffuse shot adds the first bounce exactly: D + 1 bounces in all.)
    double converged_fraction(double albedo) const override {
        return truncation_factor(albedo, options_.depth + (t_.diffuse_shot() ? 1 : 0), options_.unbiased);
    }

    // The radiance the walks converge to on a homogeneous closed scene, relative to
    // its exact radiance: 1 - a^(D+1) when truncated, 1 with `unbiased`.
    static double truncation_factor(double albedo, int depth, bool unbiased);

private:
    GlobalWalks(const Transport& transport, std::unique_ptr<visibility::BackendSet> own,
                visibility::BackendSet* backends, WalkMethod method, const SolverOptions& options,
                const sampling::RunOptions& run);
    void walk_plain();
    void walk_combined(bool both);
    // One walk along dirs_ (computes the matrices): its estimate into walk_.
    void evaluate();
    // The walk at `point` (2 depth coordinates), into walk_; its importance.
    double evaluate_at(const double* point);
    double importance() const;  // of walk_, without the floor
    void advance_vegas();
    void advance_metropolis();
    void seed_metropolis();
    void start_chains();
    long seed_target() const;
    // The geometry matrices of the walk's directions, dirs_ -> matrices_.
    void transfer_all();
    // Adds one walk's estimate for patch i (irradiance that arrived along `arrived`) to
    // sum_: the irradiance itself (diffuse scene) or the radiance it sends to the eye.
    void accumulate(std::size_t i, const Vec3& arrived, const Rgb& irradiance);
    // The emission of the walk's transfers along `out`: own + first shot + correction.
    Rgb walk_emission(std::size_t j, const Vec3& out) const;

    const Transport& t_;
    std::unique_ptr<visibility::BackendSet> own_set_;
    visibility::BackendSet& backends_;
    WalkMethod method_;
    SolverOptions options_;
    sampling::RunOptions run_;
    bool glossy_;
    sampling::WalkSampler sampler_;
    sampling::Rng jitter_;
    std::vector<Vec3> dirs_;
    std::vector<Vec3> to_eye_;
    std::vector<Eigen::Vector2d> jitters_;
    std::vector<visibility::GeometryMatrix> matrices_;  // one per direction of the walk

    // Per patch (slots() long): plain walk: max-bounce irradiance I and, with
    // `unbiased`, the exact-bounce chain J; combined: the table (glossy) or the running
    // sums per bounce (diffuse).
    std::vector<Rgb> irr_, chain_, out_, next_;
    std::vector<std::vector<Rgb>> table_;
    // The unbiased correction: the previous walk's last-bounce irradiance (per patch),
    // and the direction it arrived along (with both: +-, per patch by its normal).
    std::vector<Rgb> correction_;
    Vec3 correction_dir_ = Vec3::Zero();
    bool correction_both_ = false;
    double correction_scale_ = 0.0;  // 0: none yet

    std::vector<Rgb> sum_;   // per patch: sum over walks of the reflected-radiance estimate
    std::vector<Rgb> walk_;  // per patch: the current walk's estimate
    long walks_done_ = 0;
    SolverReport report_;

    // Importance sampling (vegas, metropolis).
    ImportanceWeights weights_;
    sampling::Rng adaptive_rng_;
    std::vector<double> point_, proposal_;
    double floor_ = 0.0;
    sampling::VegasTables vegas_;
    long phase_walks_ = 0;
    struct Chain {
        std::vector<double> point;
        std::vector<Rgb> estimate;
        double importance = 0.0;  // with the floor
        sampling::Reservoir seeds;  // seeding: picks the first walk in proportion to importance
    };
    std::vector<Chain> chains_;
    std::vector<Rgb> seed_sum_;  // per patch: the seed walks' sum (the field until the first step)
    bool seeding_ = true;
    // The large steps' density, learnt from the chains' steps and refreshed after
    // kFirstRefresh, then kRefreshGrowth times more, steps, and at the last learning
    // step.
    sampling::MixtureLearner learner_;
    long learnt_ = 0, next_refresh_ = 0, imaged_ = 0;  // learning steps, then the image's
    long learning_steps() const;
    // The exposure b without the floor, from every independent walk (the seeds,
    // uniform, and the large steps, from the density of their period): each density's
    // sum of I / p_k, weighed by a trust fixed in advance.
    sampling::MixtureEstimate exposure_;
    double exposure() const;
    long seeds_done_ = 0, proposed_ = 0, accepted_ = 0;
    double acceptance_sum_ = 0.0;
};

}  // namespace raybundle::solver
