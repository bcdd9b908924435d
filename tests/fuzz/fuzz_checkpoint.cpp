// libFuzzer harness for the checkpoint reader (render/checkpoint.h) and what --resume
// does with what it read. An input is a checkpoint without its last 8 bytes (the
// checksum): the harness appends the checksum of the rest, so that mutations reach
// the header and the chains instead of stopping at the checksum (a checksum that does
// not match is one comparison, tested in tests/render/test_run.cpp). Then:
// - parse_checkpoint either reads it or throws CheckpointError;
// - what it read is the same run as itself (require_same_run of its identity with
//   itself; the comparison is as the run means it, numbers and -D order canonical);
// - its two chain states restore into two solvers of the homogeneous box at patch
//   size 0.5 (the solve its seeds come from) of the method its identity names
//   (--method, --sampler, --depth), or throw StateError.
// A crash, a sanitizer report, another exception, or more than the run's memory or
// time limits is a finding (scripts/fuzz.sh).
#include "render/checkpoint.h"
#include "sampling/walk_sampler.h"
#include "scenes/builtin.h"
#include "scenes/errors.h"
#include "solver/solver.h"
#include "solver/transport.h"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <tuple>

namespace {

namespace rb = raybundle;

// The checkpoint's checksum: FNV-1a 64 of every byte before it (render/checkpoint.cpp).
std::uint64_t fnv1a(const std::string& bytes) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ull;
    return h;
}

// The first value of an identity option, or `otherwise`.
std::string option(const nlohmann::json& identity, const char* flag, const std::string& otherwise) {
    const auto& options = identity.at("options");
    if (!options.contains(flag) || !options[flag].is_array() || options[flag].empty() ||
        !options[flag][0].is_string())
        return otherwise;
    return options[flag][0].get<std::string>();
}

struct Solvers {
    std::unique_ptr<rb::solver::Solver> a, b;
};

const rb::solver::Transport& transport() {
    static const rb::scenes::Scene scene = rb::scenes::make_builtin("homogeneous-box", 0.5);
    static const rb::solver::Transport t(scene, rb::solver::ShotOptions{}, rb::sampling::RunOptions{});
    return t;
}

// The two chains' solvers of a method, made once: a restore replaces all they keep.
Solvers* solvers(const std::string& method, const std::string& sampler, int depth) {
    static std::map<std::tuple<std::string, std::string, int>, Solvers> made;
    const auto key = std::make_tuple(method, sampler, depth);
    if (auto it = made.find(key); it != made.end()) return it->second.a ? &it->second : nullptr;
    Solvers& s = made[key];
    rb::solver::SolverOptions options;
    options.method = method;
    options.depth = depth;
    rb::sampling::RunOptions run;
    run.threads = 1;
    try {
        options.sampler = rb::sampling::parse_sampler(sampler);
        run.chain = 0;
        s.a = rb::solver::make_solver(transport(), options, run);
        run.chain = 1;
        s.b = rb::solver::make_solver(transport(), options, run);
    } catch (const std::exception&) {  // a method that is not one, or not with these options
        s.a.reset();
        s.b.reset();
        return nullptr;
    }
    return &s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::string bytes(reinterpret_cast<const char*>(data), size);
    const std::uint64_t sum = fnv1a(bytes);
    bytes.append(reinterpret_cast<const char*>(&sum), sizeof sum);
    rb::render::Checkpoint k;
    try {
        k = rb::render::parse_checkpoint(std::move(bytes), "fuzz.ckpt");
    } catch (const rb::render::CheckpointError&) {
        return 0;
    }
    rb::render::require_same_run("fuzz.ckpt", k.identity, k.identity);  // throws nothing
    if (k.states.size() != 2) __builtin_trap();
    // Only a small set of methods, so that the solvers made stay few.
    const std::string method = option(k.identity, "--method", "iteration");
    const std::string sampler = option(k.identity, "--sampler", "random");
    const std::string depth = option(k.identity, "--depth", std::to_string(rb::solver::SolverOptions{}.depth));
    if (method.size() > 16 || sampler.size() > 16 || depth.size() != 1 || depth[0] < '1' || depth[0] > '8') return 0;
    Solvers* s = solvers(method, sampler, depth[0] - '0');
    if (!s) return 0;
    for (auto [solver, state] : {std::make_pair(s->a.get(), &k.states[0]), std::make_pair(s->b.get(), &k.states[1])}) {
        try {
            rb::solver::StateReader in(*state);
            solver->restore(in);
            in.finish();
        } catch (const rb::solver::StateError&) {
        }
    }
    return 0;
}
