#pragma once
// Patches sorted along a direction w by the depth of their centres: the processing
// order of the painter's algorithms (004 section 5.1.3).
//
// Each key is the centre's depth from the scene's centre quantised to 32 bits over the
// bounding sphere's diameter, then "is a source" (n . w > 0; at equal depth receivers
// go first, so a two-sided panel of two coincident opposite triangles does not leak),
// then the patch index (31 bits). A stable LSD radix sort on the top 33 bits keeps
// equal keys in index order, so a direction costs O(n).
#include "scenes/scene.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace raybundle::visibility {

// The patch index of a sorted key.
inline std::uint32_t sorted_patch(std::uint64_t key) { return static_cast<std::uint32_t>(key & 0x7FFFFFFFu); }

namespace detail {

// Stable LSD radix sort of 64-bit keys by their top 33 bits (bits 31..63), in three
// passes of 11 bits.
inline void radix_sort_top33(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
    constexpr int kBits = 11, kBuckets = 1 << kBits;
    scratch.resize(keys.size());
    std::uint32_t count[kBuckets];
    for (int shift = 31; shift < 64; shift += kBits) {
        std::fill(count, count + kBuckets, 0u);
        for (const std::uint64_t k : keys) ++count[(k >> shift) & (kBuckets - 1)];
        std::uint32_t sum = 0;
        for (auto& c : count) {
            const std::uint32_t here = c;
            c = sum;
            sum += here;
        }
        for (const std::uint64_t k : keys) scratch[count[(k >> shift) & (kBuckets - 1)]++] = k;
        keys.swap(scratch);
    }
}

}  // namespace detail

// Fills `keys` with every patch, upstream along w first.
inline void sort_by_centre(const scenes::Vec3& w, const std::vector<scenes::Vec3>& normals,
                           const std::vector<scenes::Vec3>& centroids, const scenes::Vec3& center, double radius,
                           std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& scratch) {
    const std::size_t n = normals.size();
    keys.resize(n);
    const double depth_scale = 0.5 * 4294967295.0 / radius;
    for (std::size_t i = 0; i < n; ++i) {
        const double depth = w.dot(centroids[i] - center);
        const double q = std::clamp((depth + radius) * depth_scale, 0.0, 4294967295.0);
        const std::uint64_t source = normals[i].dot(w) > 0.0 ? 1 : 0;
        keys[i] = (static_cast<std::uint64_t>(q) << 32) | (source << 31) | i;
    }
    detail::radix_sort_top33(keys, scratch);
}

}  // namespace raybundle::visibility
