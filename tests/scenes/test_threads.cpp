#include "scenes/threads.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <random>
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
