#pragma once
// Geometry-matrix entries from per-pixel (receiver, source) pairs: the discrete
// backends that find pairs pixel by pixel (global z-buffer, ray casting) record one
// key per pixel and turn them into one entry per pair, grouped by receiver.
#include "visibility/backend.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace raybundle::visibility {

inline std::uint64_t pixel_pair(std::uint32_t receiver, std::uint32_t source) {
    return static_cast<std::uint64_t>(receiver) << 32 | source;
}

// After sorting the surfaces along one ray (or over one face) by depth: runs of
// surfaces at the same place up to rounding (consecutive depths within tolerance) are
// put receivers first, as the exact order requires. Two opposite triangles at the same
// place (a two-sided panel) then never let light through, however their depths round.
template <class It, class Depth, class IsSource>
void receivers_first_at_ties(It first, It last, double tolerance, Depth depth, IsSource is_source) {
    for (It a = first; a != last;) {
        It b = a + 1;
        while (b != last && depth(*b) - depth(*(b - 1)) <= tolerance) ++b;
        if (b - a > 1) std::stable_partition(a, b, [&](const auto& x) { return !is_source(x); });
        a = b;
    }
}

// Sorts `pairs` and appends one entry per distinct pair: its pixel count times
// pixel_area.
inline void entries_from_pairs(std::vector<std::uint64_t>& pairs, double pixel_area,
                               std::vector<TransferEntry>& out) {
    std::sort(pairs.begin(), pairs.end());
    for (std::size_t k = 0; k < pairs.size();) {
        std::size_t e = k;
        while (e < pairs.size() && pairs[e] == pairs[k]) ++e;
        out.push_back({static_cast<std::uint32_t>(pairs[k] >> 32), static_cast<std::uint32_t>(pairs[k]),
                       static_cast<double>(e - k) * pixel_area});
        k = e;
    }
}

}  // namespace raybundle::visibility
