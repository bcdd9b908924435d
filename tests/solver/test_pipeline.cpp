// The pipeline that runs chains' steps on shared threads (solver/pipeline.h): every item
// begun, computed and finished once, begun and finished in order, never more than the
// window under way, one finisher per stream at a time; go_on stops every stream at one
// item; an exception stops it; and a
// solver's steps run as a stream with another chain's are those it makes alone.
#include "scenes/builtin.h"
#include "solver/global_walks.h"
#include "solver/pipeline.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <atomic>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

using namespace raybundle;

namespace {

// A backend that computes nothing: the pipeline only hands it on.
class NoBackend final : public visibility::Backend {
public:
    std::string name() const override { return "none"; }
    int resolution() const override { return 0; }
    void transfer(const visibility::Vec3&, const Eigen::Vector2d&, visibility::GeometryMatrix&) override {}
};

// A stream of `count` items: begin stores the item in its slot, compute its square (after
// a wait that differs from item to item, so that items end out of order), finish
// checks the order and keeps the result; every breach is counted.
struct Recorded {
    std::vector<long> slot_item, slot_value, finished;
    long next_begin = 0;
    std::atomic<long> under_way{0}, most_under_way{0}, finishers{0}, computed{0}, breaches{0};
    std::vector<NoBackend> backends;

    solver::StepStream stream(long count, long window, int own_backends) {
        slot_item.assign(static_cast<std::size_t>(window), -1);
        slot_value.assign(static_cast<std::size_t>(window), -1);
        backends.resize(static_cast<std::size_t>(own_backends));
        solver::StepStream s;
        s.count = count;
        s.window = window;
        for (auto& b : backends) s.backends.push_back(&b);
        s.begin = [this, window](long item, long slot) {
            if (item != next_begin++ || slot != item % window) ++breaches;
            slot_item[static_cast<std::size_t>(slot)] = item;
            const long now = ++under_way;
            long most = most_under_way.load();
            while (now > most && !most_under_way.compare_exchange_weak(most, now)) {
            }
        };
        s.compute = [this](long slot, visibility::Backend&) {
            const long item = slot_item[static_cast<std::size_t>(slot)];
            std::this_thread::sleep_for(std::chrono::microseconds(50 * ((item * 7) % 5)));
            slot_value[static_cast<std::size_t>(slot)] = item * item;
            ++computed;
        };
        s.finish = [this](long item, long slot) {
            if (++finishers != 1) ++breaches;
            if (item != static_cast<long>(finished.size()) || slot_item[static_cast<std::size_t>(slot)] != item) ++breaches;
            finished.push_back(slot_value[static_cast<std::size_t>(slot)]);
            --under_way;
            --finishers;
        };
        return s;
    }
};

}  // namespace

TEST_CASE("pipeline: every item once, begun and finished in order, within the window, on any number of threads",
          "[solver][pipeline]") {
    for (const int threads : {1, 2, 3, 5}) {
        INFO(threads << " threads");
        Recorded a, b;
        std::vector<solver::StepStream> streams{a.stream(37, 3, 2), b.stream(23, 5, 1)};
        solver::run_step_streams(streams, threads);
        for (const Recorded* r : {&a, &b}) {
            const long count = r == &a ? 37 : 23, window = r == &a ? 3 : 5;
            CHECK(r->breaches == 0);
            CHECK(r->computed == count);
            REQUIRE(r->finished.size() == static_cast<std::size_t>(count));
            for (long k = 0; k < count; ++k) CHECK(r->finished[static_cast<std::size_t>(k)] == k * k);
            CHECK(r->most_under_way <= window);
            CHECK(r->under_way == 0);
        }
    }
}

TEST_CASE("pipeline: go_on stops every stream at the item it said no to, without a pause", "[solver][pipeline]") {
    for (const int threads : {1, 2, 3, 5}) {
        INFO(threads << " threads");
        // No at item 13: each stream finishes items 0..12 and never begins the others;
        // go_on is asked for items 0..13, once each, in order.
        Recorded a, b;
        std::vector<solver::StepStream> streams{a.stream(37, 3, 2), b.stream(23, 5, 1)};
        std::vector<long> asked;
        const long ran = solver::run_step_streams(streams, threads, [&](long item) {
            asked.push_back(item);
            return item < 13;
        });
        CHECK(ran == 13);
        for (const Recorded* r : {&a, &b}) {
            CHECK(r->breaches == 0);
            CHECK(r->next_begin == 13);
            CHECK(r->computed == 13);
            CHECK(r->finished.size() == 13);
            CHECK(r->under_way == 0);
        }
        REQUIRE(asked.size() == 14);
        for (std::size_t k = 0; k < asked.size(); ++k) CHECK(asked[k] == static_cast<long>(k));
        // Never no: every item of both, go_on asked up to the longest stream's last item.
        Recorded c, d;
        std::vector<solver::StepStream> all{c.stream(37, 3, 2), d.stream(23, 5, 1)};
        long most = 0;
        CHECK(solver::run_step_streams(all, threads, [&](long item) { return most = std::max(most, item), true; }) == 37);
        CHECK(most == 36);
        CHECK(c.finished.size() == 37);
        CHECK(d.finished.size() == 23);
        // No at an item past a stream's count: that stream ran all of its items.
        Recorded e, f;
        std::vector<solver::StepStream> past{e.stream(37, 3, 2), f.stream(23, 5, 1)};
        CHECK(solver::run_step_streams(past, threads, [](long item) { return item < 30; }) == 30);
        CHECK(e.finished.size() == 30);
        CHECK(f.finished.size() == 23);
        // No at once (a stop before the call): nothing begun.
        Recorded g, h;
        std::vector<solver::StepStream> none{g.stream(37, 3, 2), h.stream(23, 5, 1)};
        CHECK(solver::run_step_streams(none, threads, [](long) { return false; }) == 0);
        CHECK(g.next_begin == 0);
        CHECK(h.next_begin == 0);
    }
}

TEST_CASE("pipeline: a callback's exception stops every thread and is rethrown", "[solver][pipeline]") {
    Recorded a, b;
    std::vector<solver::StepStream> streams{a.stream(40, 4, 2), b.stream(40, 4, 2)};
    auto compute = streams[1].compute;
    streams[1].compute = [compute, &b](long slot, visibility::Backend& backend) {
        if (b.slot_item[static_cast<std::size_t>(slot)] == 9) throw std::runtime_error("item 9 failed");
        compute(slot, backend);
    };
    CHECK_THROWS_WITH(solver::run_step_streams(streams, 4), "item 9 failed");
    CHECK(b.finished.size() <= 9);  // the items after the failed one are never finished
    std::vector<solver::StepStream> none(1);  // no backend to run on
    CHECK_THROWS_AS(solver::run_step_streams(none, 2), std::logic_error);
}

TEST_CASE("pipeline: two chains' steps on shared threads are those each makes alone", "[solver][pipeline]") {
    // Stochastic iteration and bidirectional walks on the Cornell box: two chains run
    // as streams together on 3 threads (each chain one backend of its own, the third
    // thread none) give, bit for bit, the fields of each chain advanced alone on one
    // thread, however the steps are split into calls.
    const auto scene = scenes::make_builtin("cornell-box");
    auto same = [](const solver::RadianceField& x, const solver::RadianceField& y) {
        if (x.radiance.size() != y.radiance.size()) return false;
        for (std::size_t i = 0; i < x.radiance.size(); ++i)
            if (!(x.radiance[i] == y.radiance[i]).all()) return false;
        return true;
    };
    const solver::Transport transport(scene);
    for (const std::string method : {"iteration", "bidirectional"}) {
        INFO(method);
        solver::SolverOptions options;
        options.method = method;
        options.steps = 60;
        options.map.resolution = 64;
        auto make = [&](std::uint64_t chain, int threads) {
            sampling::RunOptions run;
            run.seed = 7;
            run.chain = chain;
            run.threads = threads;
            return solver::make_solver(transport, options, run);
        };
        auto alone_a = make(0, 1), alone_b = make(1, 1);
        alone_a->advance(60);
        alone_b->advance(60);
        auto a = make(0, 1), b = make(1, 2);
        for (const long count : {25L, 35L}) {
            std::vector<solver::StepStream> both;
            for (auto* s : {a.get(), b.get()}) {
                auto stream = s->stream(count, true);
                REQUIRE(stream);
                both.push_back(std::move(*stream));
            }
            solver::run_step_streams(both, 3);
        }
        CHECK(a->averaged() == alone_a->averaged());
        CHECK(b->averaged() == alone_b->averaged());
        CHECK(same(a->field(), alone_a->field()));
        CHECK(same(b->field(), alone_b->field()));
        CHECK(a->report().steps == 60);
    }
}
