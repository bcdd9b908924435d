#pragma once
// Every random stream of the program, in one registry: stream k of seed s
// (Rng(s, k)) is the same sequence on every machine and thread count, so results
// depend on the seed alone as long as no two uses share a stream. Each use owns a
// range of stream numbers; the ranges are checked for overlaps at compile time.
//
// Add a use here, never as a literal at the call site.
#include <cstdint>
#include <stdexcept>
#include <string>

namespace raybundle::sampling::streams {

struct Range {
    const char* name;
    std::uint64_t first, count;
    // The k-th stream of the range; k must be below count.
    std::uint64_t operator[](std::uint64_t k) const {
        if (k >= count) throw std::out_of_range(std::string("random stream ") + name + "[" + std::to_string(k) + "]");
        return first + k;
    }
};

inline constexpr Range kDirections{"directions", 0x5eed, 1};          // stochastic iteration's directions
inline constexpr Range kWalkShifts{"walk shifts", 0x9a17, 1};         // QMC randomisation of the walk samplers
inline constexpr Range kMapJitters{"map jitters", 0x717e4, 1u << 16};  // per jitter stream of a run
inline constexpr Range kWalks{"walks", 0x3a1c0000ull, 1ull << 32};    // random walk m
inline constexpr Range kGuidePixels{"guide pixels", 1ull << 40, 1ull << 32};    // the guide sample of pixel p
inline constexpr Range kSamplePixels{"sample pixels", 2ull << 40, 1ull << 32};  // its further samples

inline constexpr Range kPathPixels{"path pixels", 3ull << 40, 1ull << 32};    // the path tracer's pixel p
inline constexpr Range kAll[] = {kDirections,  kWalkShifts,   kMapJitters, kWalks,
                                 kGuidePixels, kSamplePixels, kPathPixels};

constexpr bool disjoint() {
    for (const Range& a : kAll)
        for (const Range& b : kAll)
            if (&a != &b && a.first < b.first + b.count && b.first < a.first + a.count) return false;
    return true;
}
static_assert(disjoint(), "two uses of random streams overlap: give each its own range");

}  // namespace raybundle::sampling::streams
