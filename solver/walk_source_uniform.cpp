// Uniform walks: random, Halton or Sobol points (sampling/walk_sampler.h), every walk
// weighing 1. Walk m is a pure function of (seed, chain, m): nothing to save.
#include "solver/walk_source.h"

#include "sampling/walk_sampler.h"

namespace raybundle::solver {

namespace {

class UniformSource final : public WalkSource {
public:
    UniformSource(const SolverOptions& options, const sampling::RunOptions& run)
        : sampler_(options.sampler, options.depth, run.seed, run.chain), dims_(2 * options.depth) {}

    bool adapts() const override { return false; }

    void propose(long walk, double* point) override {
        sampler_.start_walk(static_cast<std::uint64_t>(walk));
        for (int k = 0; k < dims_; ++k) point[k] = sampler_.coordinate(k);
    }

    void accept(std::vector<Rgb>& estimate, double, std::vector<Rgb>& sum) override {
        for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += estimate[i];
    }

private:
    sampling::WalkSampler sampler_;
    int dims_;
};

}  // namespace

std::unique_ptr<WalkSource> make_uniform_source(const SolverOptions& options, const sampling::RunOptions& run) {
    return std::make_unique<UniformSource>(options, run);
}

}  // namespace raybundle::solver
