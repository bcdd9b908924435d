// Solver::save / restore (solver/state.h): a solver saved after k steps and restored
// into a fresh one goes on bit-identically, for every method; bytes of another method,
// option set or scene, or cut short, are refused.
#include "reference.h"
#include "scenes/builtin.h"
#include "solver/solver.h"

#include <catch2/catch.hpp>

#include <string>

using namespace raybundle;

namespace {

bool same(const solver::RadianceField& a, const solver::RadianceField& b) {
    bool equal = a.radiance.size() == b.radiance.size() && a.corners.size() == b.corners.size();
    for (std::size_t i = 0; equal && i < a.radiance.size(); ++i) equal = (a.radiance[i] == b.radiance[i]).all();
    for (std::size_t i = 0; equal && i < a.corners.size(); ++i)
        for (int k = 0; k < 3; ++k) equal = equal && (a.corners[i][k] == b.corners[i][k]).all();
    return equal;
}

std::string saved(const solver::Solver& s) {
    solver::StateWriter out;
    s.save(out);
    return out.bytes();
}

}  // namespace

TEST_CASE("checkpoints: save after k steps, restore into a fresh solver, go on: bit-identical", "[solver][checkpoint]") {
    const auto box = scenes::make_builtin("cornell-box", 100.0);
    const auto glossy = testing::glossy_box(0.34);
    struct Case {
        const char* name;
        const scenes::Scene* scene;
        solver::SolverOptions options;
        long stop = 13;  // steps before the save
    };
    std::vector<Case> cases;
    auto add = [&](const char* name, const scenes::Scene& scene, auto&& set) {
        solver::SolverOptions o;
        o.steps = 40;
        o.map.resolution = 64;
        set(o);
        cases.push_back({name, &scene, o});
    };
    add("iteration", box, [](auto&) {});
    add("iteration, ambient", box, [](auto& o) { o.ambient = true; });
    add("iteration, ambient and frames", box, [](auto& o) {
        o.ambient = true;
        o.frame = true;
    });
    add("iteration, glossy", glossy, [](auto&) {});
    add("iteration, linear basis", box, [](auto& o) { o.basis = "linear"; });
    add("walk, unbiased", box, [](auto& o) {
        o.method = "walk";
        o.depth = 3;
        o.unbiased = true;
    });
    add("combined, glossy", glossy, [](auto& o) {
        o.method = "combined";
        o.depth = 3;
    });
    add("walk, vegas", box, [](auto& o) {
        o.method = "walk";
        o.depth = 3;
        o.sampler = sampling::SamplerKind::vegas;
    });
    add("walk, metropolis, stopped while seeding", box, [](auto& o) {
        o.method = "walk";
        o.depth = 3;
        o.sampler = sampling::SamplerKind::metropolis;
        o.seed_walks = 20;  // the 13th step is a seed walk
    });
    add("walk, metropolis, stopped in the image's steps", box, [](auto& o) {
        o.method = "walk";
        o.depth = 3;
        o.sampler = sampling::SamplerKind::metropolis;
        o.seed_walks = 4;  // then 7 learning steps; the 13th step goes into the image
    });
    add("walk, metropolis, stopped after density refreshes", box, [](auto& o) {
        o.method = "walk";
        o.depth = 3;
        o.sampler = sampling::SamplerKind::metropolis;
        o.steps = 200;
        o.seed_walks = 2;  // then 39 learning steps: refreshed after 16, 20 and 25, stopped at 28
    });
    cases.back().stop = 30;
    add("combined, metropolis, glossy", glossy, [](auto& o) {  // stopped while learning
        o.method = "combined";
        o.depth = 3;
        o.sampler = sampling::SamplerKind::metropolis;
        o.seed_walks = 8;
    });
    add("bidirectional, sobol", box, [](auto& o) {
        o.method = "bidirectional";
        o.depth = 4;
        o.sampler = sampling::SamplerKind::sobol;
    });
    for (const auto& c : cases) {
        SECTION(c.name) {
            const solver::Transport transport(*c.scene);
            sampling::RunOptions run;
            run.seed = 7;
            run.threads = 2;
            auto whole = solver::make_solver(transport, c.options, run);
            whole->advance(c.options.steps);
            // Stopped after 13 steps (not a multiple of the batch of 8 directions), saved,
            // restored into a new solver (one thread: the result does not depend on it).
            auto first = solver::make_solver(transport, c.options, run);
            first->advance(c.stop);
            const std::string bytes = saved(*first);
            sampling::RunOptions one = run;
            one.threads = 1;
            auto second = solver::make_solver(transport, c.options, one);
            solver::StateReader in(bytes);
            second->restore(in);
            in.finish();
            CHECK(second->averaged() == first->averaged());
            CHECK(same(second->field(), first->field()));
            second->advance(c.options.steps - c.stop);
            CHECK(same(second->field(), whole->field()));
            CHECK(second->report().steps == whole->report().steps);
            CHECK(second->report().directions == whole->report().directions);
            CHECK(second->report().entries_total == whole->report().entries_total);
        }
    }
}

TEST_CASE("checkpoints: a state of another method, option set or scene, or cut short, is refused",
          "[solver][checkpoint]") {
    const auto box = scenes::make_builtin("cornell-box", 100.0);
    const auto smaller = scenes::make_builtin("cornell-box", 200.0);
    const solver::Transport transport(box), other(smaller);
    solver::SolverOptions iteration;
    iteration.steps = 10;
    iteration.map.resolution = 32;
    auto a = solver::make_solver(transport, iteration, {});
    a->advance(5);
    const std::string bytes = saved(*a);
    auto refused = [&](const solver::Transport& t, const solver::SolverOptions& o, const std::string& b) {
        auto s = solver::make_solver(t, o, {});
        solver::StateReader in(b);
        try {
            s->restore(in);
            in.finish();
        } catch (const solver::StateError&) {
            return true;
        }
        return false;
    };
    CHECK_FALSE(refused(transport, iteration, bytes));
    solver::SolverOptions walk = iteration;
    walk.method = "walk";
    CHECK(refused(transport, walk, bytes));
    solver::SolverOptions ambient = iteration;
    ambient.ambient = true;
    CHECK(refused(transport, ambient, bytes));
    CHECK(refused(other, iteration, bytes));  // another patch count
    for (const std::size_t cut : {std::size_t{0}, std::size_t{7}, bytes.size() / 2, bytes.size() - 1})
        CHECK(refused(transport, iteration, bytes.substr(0, cut)));
    CHECK(refused(transport, iteration, bytes + "x"));  // bytes left over
}
