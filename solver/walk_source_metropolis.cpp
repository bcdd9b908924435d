// Metropolis walks (004 eq. 37-41): 4 chains per solver chain, taking steps in turn (a
// fixed count: the result does not depend on the threads).
//
// Seeds. The first `seed_walks` walks of the chain's budget (default 30 % of them; more
// while none brings light to the image) are uniform: each chain's first walk is one
// of them, picked in proportion to its importance (8.1.2: the chains start in the
// stationary distribution; one weighted reservoir per chain, so that no seed is
// evaluated twice). The importance gets a floor f, 1 % of the seeds' mean, so that the
// light of walks the camera does not see keeps a chance.
//
// Steps. Every step either perturbs the chain's walk (sampling::Mutation, delta =
// mutation_size; accepted with a = min(1, I(z') / I(z))) or, with probability
// large_step, draws a new walk from a density p learnt from the chains
// (sampling/mixture.h: a mixture of one-direction components, since light through an
// opening needs one of the walk's directions in its cone; accepted with
// a = min(1, I(z') p(z) / (I(z) p(z')))). The next 20 % of the steps after the seeds
// teach the density (refreshed after 16, 20, 25, ... of them and at the last) and stay
// out of the image (none with large_step 0); then it is fixed, so that the chains are
// plain Metropolis-Hastings (adapting all along biased the homogeneous box by 3 % at
// 1,200 walks). Every other step adds the expected value of both walks (8.2):
// b (a X(z') / I(z') + (1 - a) X(z) / I(z)); the field is their mean.
//
// Exposure. b (8.1.3), the integral of the importance, comes from every independent
// walk: the seeds (uniform) and the large steps (from p), each density's sum of I / p
// weighed by a trust fixed in advance (sampling::MixtureEstimate): far less
// heavy-tailed than the uniform walks' mean, and unbiased. Until the first image step
// the field is the seeds' mean (a run of random walks). GlobalWalks::averaged() counts
// every walk, seeds included, so that it grows with the run as the pipeline's rounds
// need. Consistent, not unbiased: b is estimated, and 004 section 8.4 bounds the
// start-up bias (tests/solver/test_importance_sampling.cpp).
#include "solver/walk_source.h"

#include "sampling/adaptive.h"
#include "sampling/mixture.h"
#include "sampling/streams.h"

#include <algorithm>
#include <cmath>

namespace raybundle::solver {

namespace {

constexpr int kChains = 4;
constexpr long kFirstRefresh = 16;       // steps before the large steps' density is first learnt
constexpr double kRefreshGrowth = 1.25;  // then refreshed after 1.25 times as many
constexpr double kLearningShare = 0.2;   // of the steps after the seeds: learning, then the density is fixed

class MetropolisSource final : public WalkSource {
public:
    MetropolisSource(const SolverOptions& options, const sampling::RunOptions& run, std::size_t patches)
        : options_(options),
          rng_(run.seed, sampling::streams::kAdaptiveWalks[run.chain]),
          point_(static_cast<std::size_t>(2 * options.depth), 0.0),
          proposal_(point_),
          chains_(kChains, Chain{point_, std::vector<Rgb>(patches, Rgb::Zero()), 0.0, {}}),
          seed_sum_(patches, Rgb::Zero()),
          learner_(options.depth),
          exposure_(options.depth) {}

    bool adapts() const override { return true; }
    std::size_t vectors() const override { return kChains + 1; }

    void propose(long, double* point) override {
        if (seeding_) {
            for (double& u : point_) u = rng_.uniform();
            std::copy(point_.begin(), point_.end(), point);
            return;
        }
        const Chain& c = chains_[current()];
        // A large step draws the walk anew from the learnt density p: an independence
        // proposal, accepted by the Metropolis-Hastings ratio I(z') p(z) / (I(z) p(z')).
        // A small step perturbs the walk (symmetric).
        large_ = rng_.uniform() < options_.large_step;
        proposal_over_current_ = 1.0;
        if (large_) {
            const sampling::DirectionMixture& p = exposure_.current();
            proposal_over_current_ = p.sample(rng_, proposal_.data()) / p.density(c.point.data());
        } else {
            sampling::Mutation{options_.mutation_size}(c.point.data(), proposal_.data(), 2 * options_.depth, rng_);
        }
        std::copy(proposal_.begin(), proposal_.end(), point);
    }

    void accept(std::vector<Rgb>& estimate, double raw, std::vector<Rgb>& sum) override {
        if (seeding_) {
            seed(estimate, raw);
            // Where the image is lit through a small opening every seed may miss it: the
            // seeding goes on until one brings light to the image (in a scene whose image
            // stays dark, the whole run is uniform walks).
            if (seeds_done_ >= seed_target() && exposure_.mean() > 0.0) start_chains();
            return;
        }
        Chain& c = chains_[current()];
        const double importance = raw + floor_;
        if (large_) exposure_.add(proposal_.data(), raw);  // an independent walk: a sample of b
        const double a = std::min(1.0, importance / (c.importance * proposal_over_current_));
        if (learnt_ < learning_steps()) {
            // Learning: the density learns from the step's expected value (both walks,
            // weighed by a) and is refreshed now and then; the step stays out of the image.
            learner_.learn(proposal_.data(), a);
            learner_.learn(c.point.data(), 1.0 - a);
            ++learnt_;
            if (learnt_ == next_refresh_ || learnt_ == learning_steps()) {
                exposure_.draw_from(learner_.mixture(), std::sqrt(1.0 + static_cast<double>(learnt_)));
                next_refresh_ =
                    std::max(next_refresh_ + 1, static_cast<long>(kRefreshGrowth * static_cast<double>(next_refresh_)));
            }
        } else {
            // The expected value of the step (004 section 8.2): both walks, weighed by a;
            // the exposure b multiplies the sum when it is read (mean()).
            const double new_weight = a / importance, old_weight = (1.0 - a) / c.importance;
            for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += new_weight * estimate[i] + old_weight * c.estimate[i];
            ++imaged_;
        }
        ++proposed_;
        acceptance_sum_ += a;
        if (rng_.uniform() < a) {
            c.point = proposal_;
            c.estimate.swap(estimate);
            c.importance = importance;
            ++accepted_;
        }
    }

    WalkMean mean(const std::vector<Rgb>& sum, long) const override {
        if (imaged_ == 0) return {seed_sum_, 1.0, seeds_done_};
        return {sum, exposure(), imaged_};
    }

    void save(StateWriter& out) const override {
        out.put(rng_);
        out.put(floor_);
        out.put(seeds_done_);
        out.put(seeding_);
        out.put(seed_sum_);
        for (const Chain& c : chains_) {
            out.put(c.point);
            out.put(c.estimate);
            out.put(c.importance);
            out.put(c.seeds.total);
        }
        out.put(learner_.counts());
        out.put(learner_.totals());
        out.put(learner_.marginals());
        out.put(learner_.marginal_total());
        out.put(learnt_);
        out.put(next_refresh_);
        out.put(imaged_);
        out.put(exposure_.current().uniform);
        out.put(exposure_.current().weights);
        out.put(exposure_.current().cells);
        out.put(exposure_.trust());  // its count first, which restore() bounds before allocating
        out.put(exposure_.counts());
        out.put(exposure_.sums());
        out.put(proposed_);
        out.put(accepted_);
        out.put(acceptance_sum_);
    }

    void restore(StateReader& in) override {
        in.get(rng_);
        in.get(floor_);
        in.get(seeds_done_);
        in.get(seeding_);
        in.get(seed_sum_);  // the reader checks the sizes, here and below
        for (Chain& c : chains_) {
            in.get(c.point);
            in.get(c.estimate);
            in.get(c.importance);
            in.get(c.seeds.total);
        }
        in.get(learner_.counts());
        in.get(learner_.totals());
        in.get(learner_.marginals());
        in.get(learner_.marginal_total());
        in.get(learnt_);
        in.get(next_refresh_);
        in.get(imaged_);
        sampling::DirectionMixture& p = exposure_.current();
        in.get(p.uniform);
        in.get(p.weights);
        in.get(p.cells);
        if (!p.valid(options_.depth)) throw StateError("a Metropolis density out of range");
        std::uint64_t periods = 0;
        in.get(periods);
        // Each period takes 24 bytes: a count the bytes left cannot hold is refused
        // before anything is allocated.
        if (periods < 1 || periods > in.left() / 24) throw StateError("a Metropolis period count out of range");
        exposure_.trust().resize(periods);
        exposure_.counts().resize(periods);
        exposure_.sums().resize(periods);
        for (std::uint64_t k = 0; k < periods; ++k) {
            in.get(exposure_.trust()[k]);
            if (!(exposure_.trust()[k] > 0.0)) throw StateError("a Metropolis trust out of range");
        }
        in.get(exposure_.counts());
        in.get(exposure_.sums());
        for (const Chain& c : chains_)
            for (double u : c.point)
                if (!(u >= 0.0 && u <= 1.0)) throw StateError("a Metropolis walk outside the unit cube");
        in.get(proposed_);
        in.get(accepted_);
        in.get(acceptance_sum_);
    }

    void report(SolverReport& r) const override {
        r.details["metropolis"] = {{"chains", kChains},
                                   {"mutation_size", options_.mutation_size},
                                   {"large_step", options_.large_step},
                                   {"seed_walks", seeds_done_},
                                   {"seeding", seeding_},
                                   {"exposure", exposure()},
                                   {"exposure_walks", exposure_.samples()},
                                   {"density_refreshes", exposure_.periods() - 1},
                                   {"learning_steps", learnt_},
                                   {"image_steps", imaged_},
                                   {"importance_floor", floor_},
                                   {"proposed", proposed_},
                                   {"acceptance_rate", proposed_ > 0 ? acceptance_sum_ / proposed_ : 0.0},
                                   {"accepted", proposed_ > 0 ? static_cast<double>(accepted_) / proposed_ : 0.0}};
    }

private:
    struct Chain {
        std::vector<double> point;
        std::vector<Rgb> estimate;
        double importance = 0.0;    // with the floor
        sampling::Reservoir seeds;  // seeding: picks the first walk in proportion to importance
    };

    std::size_t current() const { return static_cast<std::size_t>(proposed_ % kChains); }

    long seed_target() const {
        if (options_.seed_walks > 0) return options_.seed_walks;
        return std::max(1L, static_cast<long>(SolverOptions::kAutoSeedShare * static_cast<double>(options_.steps)));
    }

    long learning_steps() const {
        if (!(options_.large_step > 0.0)) return 0;  // nothing draws from the density
        return std::max(1L, static_cast<long>(kLearningShare * static_cast<double>(options_.steps - seed_target())));
    }

    // The exposure b with the floor, from every independent walk.
    double exposure() const { return exposure_.samples() > 0 ? exposure_.mean() + floor_ : 0.0; }

    // One seed walk: a uniform walk, a sample of the exposure and of the seeds' field,
    // and offered to every chain's reservoir (8.1.2's draw in proportion to the importance).
    void seed(const std::vector<Rgb>& estimate, double importance) {
        for (std::size_t i = 0; i < seed_sum_.size(); ++i) seed_sum_[i] += estimate[i];
        exposure_.add(point_.data(), importance);
        ++seeds_done_;
        for (Chain& c : chains_) {
            // A walk that lights nothing is never picked: no random number spent on it.
            if (importance > 0.0 && c.seeds.offer(importance, rng_.uniform())) {
                c.point = point_;
                c.estimate = estimate;
                c.importance = importance;
            }
        }
    }

    // The seeds are done (and one of them brought light to the image): the floor, and
    // the chains' first walks are their picks.
    void start_chains() {
        floor_ = 0.01 * exposure_.mean();
        for (Chain& c : chains_) c.importance += floor_;
        next_refresh_ = kFirstRefresh;
        seeding_ = false;
    }

    SolverOptions options_;
    sampling::Rng rng_;
    std::vector<double> point_, proposal_;
    std::vector<Chain> chains_;
    std::vector<Rgb> seed_sum_;  // per patch: the seed walks' sum (the field until the first step)
    bool seeding_ = true;
    double floor_ = 0.0;
    // The large steps' density, learnt from the chains' steps and refreshed after
    // kFirstRefresh, then kRefreshGrowth times more, steps, and at the last learning step.
    sampling::MixtureLearner learner_;
    long learnt_ = 0, next_refresh_ = 0, imaged_ = 0;  // learning steps, then the image's
    // The exposure without the floor: each density's sum of I / p_k, weighed by a trust
    // fixed in advance.
    sampling::MixtureEstimate exposure_;
    bool large_ = false;                  // the proposal is a large step
    double proposal_over_current_ = 1.0;  // p(z') / p(z) for a large step
    long seeds_done_ = 0, proposed_ = 0, accepted_ = 0;
    double acceptance_sum_ = 0.0;
};

}  // namespace

std::unique_ptr<WalkSource> make_metropolis_source(const SolverOptions& options, const sampling::RunOptions& run,
                                                   std::size_t patches) {
    return std::make_unique<MetropolisSource>(options, run, patches);
}

}  // namespace raybundle::solver
