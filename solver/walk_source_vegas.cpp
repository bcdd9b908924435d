// VEGAS walks (004 section 7): the walk's point is drawn from separable tables
// (sampling/adaptive.h, an 8 x 8 table over the unit square per direction), its
// estimate weighs 1 / p(z) (eq. 33: unbiased for any tables), and the tables are
// refined from the importance after every phase of 64 walks. The tables' floor keeps
// p > 0 where the camera sees nothing, so that the light of unseen patches is still
// estimated.
#include "solver/walk_source.h"

#include "sampling/adaptive.h"
#include "sampling/streams.h"

#include <string>

namespace raybundle::solver {

namespace {

constexpr int kVegasBins = 8;     // per direction, bins x bins over the unit square
constexpr long kVegasPhase = 64;  // walks between refinements

class VegasSource final : public WalkSource {
public:
    VegasSource(const SolverOptions& options, const sampling::RunOptions& run)
        : rng_(run.seed, sampling::streams::kAdaptiveWalks[run.chain]),
          tables_(options.depth, kVegasBins),
          point_(static_cast<std::size_t>(2 * options.depth)) {}

    bool adapts() const override { return true; }

    void propose(long, double* point) override {
        density_ = tables_.sample(rng_, point_.data());
        std::copy(point_.begin(), point_.end(), point);
    }

    void accept(std::vector<Rgb>& estimate, double importance, std::vector<Rgb>& sum) override {
        for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += estimate[i] / density_;
        tables_.accumulate(point_.data(), importance / density_);
        if (++phase_walks_ == kVegasPhase) {
            tables_.refine();
            phase_walks_ = 0;
        }
    }

    void save(StateWriter& out) const override {
        out.put(rng_);
        out.put(tables_.weights());
        out.put(tables_.sums());
        out.put(tables_.refinements());
        out.put(phase_walks_);
    }

    void restore(StateReader& in) override {
        in.get(rng_);
        const std::size_t cells = tables_.weights().size();
        in.get(tables_.weights());
        in.get(tables_.sums());
        if (tables_.weights().size() != cells || tables_.sums().size() != cells)
            throw StateError("VEGAS tables of another depth");
        in.get(tables_.refinements());
        tables_.update_cdf();
        in.get(phase_walks_);
    }

    void report(SolverReport& r) const override {
        r.details["vegas"] = {{"bins", std::to_string(kVegasBins) + "x" + std::to_string(kVegasBins)},
                              {"phase_walks", kVegasPhase},
                              {"refinements", tables_.refinements()}};
    }

private:
    sampling::Rng rng_;
    sampling::VegasTables tables_;
    std::vector<double> point_;
    double density_ = 1.0;  // p(z) of the proposed point
    long phase_walks_ = 0;
};

}  // namespace

std::unique_ptr<WalkSource> make_vegas_source(const SolverOptions& options, const sampling::RunOptions& run) {
    return std::make_unique<VegasSource>(options, run);
}

}  // namespace raybundle::solver
