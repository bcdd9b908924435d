#pragma once
// Geometry-matrix entries from per-pixel (receiver, source) pairs: the discrete
// backends that find pairs pixel by pixel (global z-buffer, ray casting) record one
// key per pixel and turn them into one entry per pair, grouped by receiver
// (entries_from_pairs, pair_entries.h).
#include "visibility/backend.h"
#include "visibility/pair_entries.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace raybundle::visibility {

inline std::uint64_t pixel_pair(std::uint32_t receiver, std::uint32_t source) {
    return static_cast<std::uint64_t>(receiver) << 32 | source;
}

// After sorting the surfaces along one ray (or over one face) by depth: runs of
// surfaces at the same place up to rounding (consecutive depths within tolerance) are
// ordered as every backend orders ties: receivers first, so that two opposite
// triangles at the same place (a two-sided panel) never let light through, however
// their depths round; then, of two patches facing the same way (coplanar overlapping
// patches), the one with the higher index in front as seen from the side they face:
// upstream among receivers, downstream among sources. So one patch of such a pair
// both receives and sends the light there.
template <class It, class Depth, class IsSource, class Index>
void order_ties(It first, It last, double tolerance, Depth depth, IsSource is_source, Index index) {
    for (It a = first; a != last;) {
        It b = a + 1;
        while (b != last && depth(*b) - depth(*(b - 1)) <= tolerance) ++b;
        if (b - a > 1)
            std::sort(a, b, [&](const auto& x, const auto& y) {
                const bool sx = is_source(x), sy = is_source(y);
                if (sx != sy) return sy;
                return sx ? index(x) < index(y) : index(x) > index(y);
            });
        a = b;
    }
}

// The pairs along one ray (or over one face) whose surfaces [first, last) are ordered
// from upstream to downstream: emit(receiver, source) for every source directly
// followed by a receiver; with a sky (`patches` = n, the patch count), also (r, n) for
// a first surface r that is a receiver (it sees the open sky upstream) and (n + 1, s)
// for a last surface s that is a source (along -w it sees the sky).
template <class It, class Patch, class IsSource, class Emit>
void pairs_along(It first, It last, Patch patch, IsSource is_source, bool sky, std::uint32_t patches, Emit emit) {
    if (first == last) return;
    for (It a = first, b = first + 1; b != last; ++a, ++b)
        if (is_source(*a) && !is_source(*b)) emit(static_cast<std::uint32_t>(patch(*b)), static_cast<std::uint32_t>(patch(*a)));
    if (sky) {
        if (!is_source(*first)) emit(static_cast<std::uint32_t>(patch(*first)), patches);
        if (is_source(*(last - 1))) emit(patches + 1, static_cast<std::uint32_t>(patch(*(last - 1))));
    }
}

}  // namespace raybundle::visibility
