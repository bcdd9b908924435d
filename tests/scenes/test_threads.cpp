#include "scenes/threads.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <atomic>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace {

// A value whose first member repeats (ties that only the second breaks), as the plane
// keys of the coplanar-overlap search repeat their normal and offset.
struct Item {
    int bucket;
    std::uint32_t index;
};
bool operator==(const Item& a, const Item& b) { return a.bucket == b.bucket && a.index == b.index; }

}  // namespace

TEST_CASE("parallel_sort gives std::sort's sequence for any thread count", "[threads]") {
    const auto less = [](const Item& a, const Item& b) { return std::tie(a.bucket, a.index) < std::tie(b.bucket, b.index); };
    std::mt19937 rng(7);
    // Below one part (4,096), fewer parts than threads (12,000: 2 parts), several rounds
    // of merges, and parts of unequal length.
    for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{12000}, std::size_t{50000},
                                std::size_t{131075}}) {
        std::vector<Item> values(n);
        for (std::size_t i = 0; i < n; ++i)
            values[i] = {static_cast<int>(rng() % 97), static_cast<std::uint32_t>(rng())};
        std::vector<Item> expected = values;
        std::sort(expected.begin(), expected.end(), less);
        for (const int threads : {1, 2, 3, 5, 8}) {
            INFO(n << " values on " << threads << " threads");
            std::vector<Item> sorted = values;
            raybundle::parallel_sort(sorted, threads, less);
            CHECK(sorted == expected);
        }
    }
}

TEST_CASE("run_threads: every index once, on the same thread in every region, also in nested and concurrent regions", "[threads]") {
    using raybundle::run_threads;
    // Regions of growing and shrinking size: each t runs once, t = 0 on the caller, and
    // t on one thread in every region (the workers are kept: worker k runs t = k).
    std::vector<std::thread::id> first(8);
    for (const int count : {8, 3, 1, 5, 8, 2}) {
        std::vector<int> runs(static_cast<std::size_t>(count), 0);
        std::vector<std::thread::id> ids(static_cast<std::size_t>(count));
        run_threads(count, [&](int t) {
            ++runs[static_cast<std::size_t>(t)];
            ids[static_cast<std::size_t>(t)] = std::this_thread::get_id();
        });
        CHECK(std::all_of(runs.begin(), runs.end(), [](int r) { return r == 1; }));
        CHECK(ids[0] == std::this_thread::get_id());
        for (int t = 1; t < count; ++t) {
            INFO("region of " << count << ", t = " << t);
            CHECK(ids[static_cast<std::size_t>(t)] != std::this_thread::get_id());
            if (first[static_cast<std::size_t>(t)] == std::thread::id()) first[static_cast<std::size_t>(t)] = ids[static_cast<std::size_t>(t)];
            CHECK(ids[static_cast<std::size_t>(t)] == first[static_cast<std::size_t>(t)]);
        }
    }
    // The workers are kept: a worker's thread has run every region of 3 (started one by
    // one, a thread would have run one).
    static thread_local int regions_here = 0;
    std::vector<int> seen(3, 0);
    for (int r = 0; r < 5; ++r) run_threads(3, [&](int t) { seen[static_cast<std::size_t>(t)] = ++regions_here; });
    CHECK(seen[1] >= 5);
    CHECK(seen[2] >= 5);
    // A body's own region (the workers are busy with the outer one) gets threads of its
    // own: every inner index runs once, on a thread other than the outer ones'.
    std::atomic<int> inner{0};
    std::vector<int> sums(3, 0);
    run_threads(3, [&](int t) {
        std::vector<int> part(4, 0);
        run_threads(4, [&](int u) {
            part[static_cast<std::size_t>(u)] = 10 * t + u;
            inner.fetch_add(1);
        });
        for (int v : part) sums[static_cast<std::size_t>(t)] += v;
    });
    CHECK(inner.load() == 12);
    CHECK(sums == std::vector<int>{6, 46, 86});
    // Two threads starting regions at once: both complete, each index once.
    std::atomic<long> total{0};
    auto regions = [&total] {
        for (int r = 0; r < 200; ++r) run_threads(3, [&total](int t) { total.fetch_add(t + 1); });
    };
    std::thread other(regions);
    regions();
    other.join();
    CHECK(total.load() == 2L * 200 * (1 + 2 + 3));
}

TEST_CASE("run_threads: the first exception in t order, after every body has returned, and the workers go on", "[threads]") {
    using raybundle::run_threads;
    std::vector<int> finished(4, 0);
    try {
        run_threads(4, [&](int t) {
            if (t == 1 || t == 3) throw std::runtime_error("body " + std::to_string(t));
            std::this_thread::sleep_for(std::chrono::milliseconds(20));  // still running when the others throw
            finished[static_cast<std::size_t>(t)] = 1;
        });
        FAIL("no exception");
    } catch (const std::runtime_error& e) {
        CHECK(std::string(e.what()) == "body 1");
    }
    CHECK(finished == std::vector<int>{1, 0, 1, 0});
    std::vector<int> runs(4, 0);
    run_threads(4, [&](int t) { runs[static_cast<std::size_t>(t)] = t + 1; });
    CHECK(runs == std::vector<int>{1, 2, 3, 4});
}
