#include "solver/solver.h"

#include "scenes/errors.h"
#include "solver/global_walks.h"
#include "solver/linear_basis.h"
#include "solver/stochastic_iteration.h"
#include "visibility/parallel.h"

#include <algorithm>

namespace raybundle::solver {

namespace {

std::string known_methods() {
    std::string known;
    for (const auto& m : method_names()) known += (known.empty() ? "" : ", ") + m;
    return known;
}

}  // namespace

VisibilityUsed describe(visibility::BackendSet& backends) {
    visibility::Backend& b = backends.front();
    return {b.name(), b.details(), visibility::backend_info(b.name()).exact, b.resolution(), backends.threads()};
}

SolverOptions decided(const SolverOptions& options, const Transport& transport) {
    SolverOptions o = options;
    const bool applies = o.method == "iteration" && o.basis == "constant";
    const bool high = applies && transport.max_reflectance() > kStableAlbedo;
    if (!o.ambient) o.ambient = high;
    if (!o.frame) o.frame = high && !transport.glossy();
    return o;
}

void save_counters(StateWriter& out, const SolverReport& r) {
    out.tag("counters");
    out.put(r.steps);
    out.put(r.directions);
    out.put(r.seconds_visibility);
    out.put(r.seconds_transport);
    out.put(static_cast<std::uint64_t>(r.entries_total));
}

void restore_counters(StateReader& in, SolverReport& r) {
    in.expect("counters");
    in.get(r.steps);
    in.get(r.directions);
    in.get(r.seconds_visibility);
    in.get(r.seconds_transport);
    r.entries_total = in.u64();
}

std::vector<std::string> method_names() { return {"iteration", "walk", "combined", "bidirectional"}; }

std::unique_ptr<Solver> make_solver(const Transport& transport, const SolverOptions& options,
                                    const sampling::RunOptions& run) {
    const auto& names = method_names();
    if (std::find(names.begin(), names.end(), options.method) == names.end())
        throw scenes::OptionError("method", "unknown method '" + options.method + "' (known: " + known_methods() + ")");
    if (options.basis != "constant" && options.basis != "linear")
        throw scenes::OptionError("basis", "unknown basis '" + options.basis + "' (known: constant, linear)");
    if (options.steps < 1) throw scenes::OptionError("steps", "must be >= 1, got " + std::to_string(options.steps));
    const bool iteration = options.method == "iteration";
    if (iteration && options.sampler != sampling::SamplerKind::random)
        throw scenes::OptionError("sampler", std::string(sampling::sampler_name(options.sampler)) +
                                                 ": stochastic iteration needs independent consecutive directions "
                                                 "(004 section 4.4); QMC samplers work with the walk methods");
    if (iteration && options.unbiased)
        throw scenes::OptionError("unbiased", "applies to the walk methods (stochastic iteration is unbiased)");
    if (!iteration && !options.both_ways)
        throw scenes::OptionError("both_ways", "applies to stochastic iteration (the walk method 'bidirectional' "
                                               "uses w and -w)");
    if ((!iteration || options.basis == "linear") && options.ambient.value_or(false))
        throw scenes::OptionError("ambient", "applies to stochastic iteration with the constant basis");
    if ((!iteration || options.basis == "linear") && options.frame.value_or(false))
        throw scenes::OptionError("frame", "applies to stochastic iteration with the constant basis");
    if (options.frame.value_or(false) && transport.glossy())
        throw scenes::OptionError("frame", "needs a purely diffuse scene (glossy patches reflect the light of one "
                                           "direction per step)");
    const SolverOptions chosen = decided(options, transport);
    visibility::BackendOptions map = options.map;
    // Sky entries for a scene with sky; without one, the void's entries only for the
    // ambient control variate (solver/stochastic_iteration.h), when the backend has them.
    map.sky = transport.scene().sky.has_value() ||
              (iteration && options.basis == "constant" && *chosen.ambient && visibility::backend_info(options.visibility).sky);
    if (options.basis == "linear") {
        if (!iteration) throw scenes::OptionError("basis", "linear works with the method 'iteration', not '" + options.method + "'");
        if (options.visibility != visibility::kDefaultBackend && options.visibility != "painter")
            throw scenes::OptionError("visibility", "the linear basis uses the centre-sorted painter's radiance map "
                                                    "(the basis lives in its rasteriser), not '" +
                                                        options.visibility + "'");
        SolverOptions o = options;
        o.map = map;
        return std::make_unique<LinearIteration>(transport, o, run);
    }
    auto backends = std::make_unique<visibility::BackendSet>(options.visibility, transport.scene(), map, run.threads);
    if (iteration) {
        SolverOptions o = options;
        o.map = map;
        return std::make_unique<StochasticIteration>(transport, std::move(backends), o, run);
    }
    const WalkMethod method = options.method == "walk"       ? WalkMethod::walk
                              : options.method == "combined" ? WalkMethod::combined
                                                             : WalkMethod::bidirectional;
    return std::make_unique<GlobalWalks>(transport, std::move(backends), method, options, run);
}

}  // namespace raybundle::solver
