// The walk sources' factory: the sampler's member of the family.
#include "solver/walk_source.h"

#include "scenes/errors.h"

#include <string>

namespace raybundle::solver {

std::unique_ptr<WalkSource> make_walk_source(const SolverOptions& options, const sampling::RunOptions& run,
                                             std::size_t patches) {
    switch (options.sampler) {
        case sampling::SamplerKind::random:
        case sampling::SamplerKind::halton:
        case sampling::SamplerKind::sobol: return make_uniform_source(options, run);
        case sampling::SamplerKind::vegas: return make_vegas_source(options, run);
        case sampling::SamplerKind::metropolis: return make_metropolis_source(options, run, patches);
    }
    std::string known;
    for (const char* name : sampling::kSamplerNames) known += (known.empty() ? "" : ", ") + std::string(name);
    throw scenes::OptionError("sampler", "unknown sampler " + std::to_string(static_cast<int>(options.sampler)) +
                                             " (known: " + known + ")");
}

}  // namespace raybundle::solver
