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
// Where the directions come from is the walk source's business (solver/walk_source.h:
// uniform random or quasi-random points, VEGAS, Metropolis): it proposes each walk's
// point, the walk is computed here, and the source accepts it into the sum. For the
// sources that adapt to the image, every walk's estimate X(z) (a vector over patches)
// has an importance I(z) = sum_p Y(w_p X_p(z)): the luminance it adds to the image
// (solver/importance.h).
//
// Options read: steps (walks), depth, unbiased, sampler, mutation_size, large_step,
// seed_walks. Call order: see solver.h.
#include "solver/importance.h"
#include "solver/solver.h"
#include "solver/walk_source.h"
#include "visibility/parallel.h"

#include <algorithm>
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
    // solver. With several backends whole walks go side by side, each on a backend (a
    // free thread takes the next walk; the walks are summed in order), or, for a source
    // that adapts and with `unbiased`, the D matrices of one walk (bit-identical results
    // for any count). Throws OptionError for a depth the sampler
    // cannot do or --unbiased with a QMC sampler.
    GlobalWalks(const Transport& transport, visibility::BackendSet& backends, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);
    GlobalWalks(const Transport& transport, visibility::Backend& backend, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);
    GlobalWalks(const Transport& transport, std::unique_ptr<visibility::BackendSet> backends, WalkMethod method,
                const SolverOptions& options, const sampling::RunOptions& run);

    void advance(long walks) override;
    std::optional<StepStream> stream(long walks, bool shared) override;
    RadianceField field(int threads = 0) const override;
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
    // One walk's directions, matrices and per-patch vectors, and the work it did (added
    // to the report when the walk is taken).
    struct Work {
        std::vector<Vec3> dirs;
        std::vector<Eigen::Vector2d> jitters;
        std::vector<visibility::GeometryMatrix> matrices;  // one per direction of the walk
        // Per patch (slots() long): plain walk: max-bounce irradiance I and, with
        // `unbiased`, the exact-bounce chain J; combined: the table (glossy) or the
        // running sums per bounce (diffuse).
        std::vector<Rgb> irr, chain, out, next;
        std::vector<std::vector<Rgb>> table;
        std::vector<Rgb> walk;  // per patch: the walk's estimate
        double seconds_visibility = 0.0, seconds_transport = 0.0;
        std::size_t entries = 0;
        long directions = 0;
    };
    void walk_plain(Work& work);
    void walk_combined(Work& work, bool both);
    // The directions of the walk at `point` (2 depth coordinates), and its jitters.
    void start_walk(Work& work, const double* point);
    // The walk (its matrices computed on `alone`, or on all the backends): its
    // estimate into work.walk.
    void evaluate(Work& work, visibility::Backend* alone);
    // The walk at `point` in work_[0]; its importance (0 for a source that does not adapt).
    double evaluate_at(const double* point);
    void draw_jitters(Work& work);
    // The geometry matrices of the walk's directions, dirs -> matrices.
    void transfer_all(Work& work, visibility::Backend* alone);
    // The walk's figures into the report, in walk order.
    void count(Work& work);
    // Adds one walk's estimate for patch i (irradiance that arrived along `arrived`) to
    // work.walk: the irradiance itself (diffuse scene) or the radiance it sends to the eye.
    void accumulate(Work& work, std::size_t i, const Vec3& arrived, const Rgb& irradiance) const;
    // The emission of the walk's transfers along `out`: own + first shot + correction.
    Rgb walk_emission(std::size_t j, const Vec3& out) const;

    const Transport& t_;
    std::unique_ptr<visibility::BackendSet> own_set_;
    visibility::BackendSet& backends_;
    WalkMethod method_;
    SolverOptions options_;
    sampling::RunOptions run_;
    bool glossy_;
    std::unique_ptr<WalkSource> source_;
    std::vector<double> point_;  // the walk's 2 depth coordinates
    sampling::Rng jitter_;
    std::vector<Vec3> to_eye_;
    std::vector<Work> work_;    // [0]: the walk under way; side by side, one per walk under way
    // Walks under way at once side by side on `threads`: a half more than the threads,
    // so that a walk slower than the others does not leave threads idle.
    static int walks_under_way(int threads) { return threads + std::max(1, threads / 2); }
    // At least `walks` in work_, and the report's bytes per patch for them.
    void grow_work(std::size_t walks);
    bool whole_walks_ = false;      // whole walks side by side (independent, no GPU batches)
    std::size_t walk_vectors_ = 0;  // per-patch vectors of one walk under way
    // The unbiased correction: the previous walk's last-bounce irradiance (per patch),
    // and the direction it arrived along (with both: +-, per patch by its normal).
    std::vector<Rgb> correction_;
    Vec3 correction_dir_ = Vec3::Zero();
    bool correction_both_ = false;
    double correction_scale_ = 0.0;  // 0: none yet

    std::vector<Rgb> sum_;  // per patch: sum over walks of the reflected-radiance estimate
    long walks_done_ = 0;
    SolverReport report_;

    ImportanceWeights weights_;  // for a source that adapts
};

}  // namespace raybundle::solver
