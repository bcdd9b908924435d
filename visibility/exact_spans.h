#pragma once
// The exact painter's inner loops: one triangle drawn into one band of the map, the
// fast path only. A pixel is in order when the patch's depth there lies clearly
// downstream of the occupant's (key > K + kDepthTie): then B = A, A = id, K = key, and
// a receiver counts the source it sees. Every other pixel is handed back for the slow
// path, which runs after the triangle: pixels do not interact.
//
// Depth keys: clamp(row0 + dy y + dx x, lo, hi) truncated to an integer below 2^31,
// evaluated as span_key() does, with the same operations in the same order everywhere
// and no fused multiply-add (the visibility library is compiled with
// -ffp-contract=off), so that every kernel and the slow path agree on every key.
//
// Kernels: portable C++, and AVX2 (8 pixels a step) where the processor has it
// (chosen at run time; the AVX2 code is compiled through target attributes, so
// nothing built for AVX2 is shared with the rest of the program). The band arrays
// must have kSpanSlack elements of slack after the band's last pixel (whole steps are
// read and written back).
#include <cstdint>
#include <vector>

namespace raybundle::visibility {

inline constexpr int kSpanSlack = 8;
inline constexpr std::int32_t kDepthTie = 2;           // keys within this many steps tie
inline constexpr std::uint32_t kSourceBit = 1u << 31;  // in an id: the patch faces w

// A patch's depth over the map: key(x, y) = clamp(row0 + dy y + dx x, lo, hi).
struct DepthPlane {
    double row0, dy, dx, lo, hi;
};
std::uint32_t span_key(const DepthPlane& plane, int x, int y);

// One band of the map (rows [y_first, y_end), W pixels each): occupant, its depth
// key, the one before it. A pixel whose key is still 0 holds `initial` (nothing, or
// the open sky) whatever A says: the band's A is never cleared.
struct Band {
    std::uint32_t* A;
    std::int32_t* K;
    std::uint32_t* B;
    int W, y_first, y_end;
    std::uint32_t initial;
};

// A triangle to draw: its projected corners (sub-pixel units, see map_grid.h), plane
// and id (the patch index, with kSourceBit for a source).
struct Triangle {
    const std::int32_t* X;
    const std::int32_t* Y;
    DepthPlane plane;
    std::uint32_t id;
};

// What the receiver being drawn has seen so far: pixels per source. `touched` has room
// for every source. Consecutive pixels mostly see the same source: they are counted as
// a run, added to `counts` when the id seen changes and at the end (flush_run()).
struct SourceCounts {
    std::uint32_t* counts;   // per source index
    std::uint32_t* touched;  // the sources with a non-zero count
    std::uint32_t touched_count;
    std::uint32_t current;   // the id seen in the current run (a source, or not)
    std::uint32_t run;
};
void flush_run(SourceCounts& seen);

// A pixel handed back: its index in the band, column, row and depth key.
struct SlowPixel {
    std::uint32_t p;
    int x, y;
    std::uint32_t key;
};

struct SpanKernels {
    const char* name;
    void (*source)(const Band& band, const Triangle& t, std::vector<SlowPixel>& slow);
    void (*receiver)(const Band& band, const Triangle& t, SourceCounts& seen, std::vector<SlowPixel>& slow);
};

// The fastest kernels this processor runs, and the portable ones.
const SpanKernels& best_span_kernels();
const SpanKernels& portable_span_kernels();

}  // namespace raybundle::visibility
