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
    // Stream `minor` of block `major`, blocks of 2^minor_bits streams: the same checks.
    std::uint64_t operator()(std::uint64_t major, std::uint64_t minor, int minor_bits) const {
        if (minor >> minor_bits != 0)
            throw std::out_of_range(std::string("random stream ") + name + ": " + std::to_string(minor) +
                                    " does not fit in " + std::to_string(minor_bits) + " bits");
        return (*this)[(major << minor_bits) | minor];
    }
};

// A run's independent chains (RunOptions::chain: the two halves whose difference
// estimates the error, and later ranks) and the passes of a progressive image draw
// from blocks of their own.
inline constexpr std::uint64_t kMaxChains = 1024;
inline constexpr std::uint64_t kMaxPasses = 1ull << 16;

inline constexpr Range kDirections{"directions", 0x5eed, kMaxChains};  // stochastic iteration's directions, per chain
inline constexpr Range kWalkShifts{"walk shifts", 0x9a17, kMaxChains};  // QMC randomisation of the walks, per chain
inline constexpr Range kAdaptiveWalks{"adaptive walks", 0x2000, kMaxChains};  // VEGAS and Metropolis walks, per chain
// Per chain, per jitter stream of a run (blocks of 2^16).
inline constexpr Range kMapJitters{"map jitters", 0x717e4, kMaxChains << 16};
inline constexpr Range kWalks{"walks", 0x3a1c0000ull, kMaxChains << 32};  // per chain, random walk m (blocks of 2^32)
// Per pass, pixel p (blocks of 2^32 pixels).
inline constexpr Range kGuidePixels{"guide pixels", 1ull << 50, kMaxPasses << 32};    // the guide sample of pixel p
inline constexpr Range kSamplePixels{"sample pixels", 2ull << 50, kMaxPasses << 32};  // its further samples
inline constexpr Range kPathPixels{"path pixels", 3ull << 50, kMaxPasses << 32};      // the path tracer's pixel p
inline constexpr Range kBiasPixels{"bias pixels", 4ull << 50, kMaxPasses << 32};      // the bias probe at guide p
inline constexpr Range kGuidePoints{"guide points", 5ull << 50, kMaxPasses << 32};     // where in pixel p its guide lies

inline constexpr Range kAll[] = {kDirections,  kWalkShifts,   kAdaptiveWalks, kMapJitters, kWalks,
                                 kGuidePixels, kSamplePixels, kPathPixels, kBiasPixels, kGuidePoints};

constexpr bool disjoint() {
    for (const Range& a : kAll)
        for (const Range& b : kAll)
            if (&a != &b && a.first < b.first + b.count && b.first < a.first + a.count) return false;
    return true;
}
static_assert(disjoint(), "two uses of random streams overlap: give each its own range");

}  // namespace raybundle::sampling::streams
