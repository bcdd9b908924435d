#pragma once
// Geometry-matrix entries from (receiver, source) pairs, sorted by (receiver, source)
// whatever the order the pairs arrived in: one key per pixel from the pixel backends
// (global z-buffer, ray casting), or pairs already counted by the z-buffer's GPU hash
// table (its slots' order depends on the GPU's scheduling).
//
// Both sort 64-bit words by radix, in as few passes of at most 12 bits as the bits
// that differ between the words need: receiver above source, each field as wide as
// the largest id present needs (the pixel backends' keys repacked from receiver << 32
// | source), and a counted pair's count below them. At the Cornell box (3,722 patches)
// that is 2 passes, at 121k patches 3. Counted pairs too wide to pack (more than 64
// bits of ids and count together: millions of patches at a large map) are sorted as
// (pair, count) records.
#include "visibility/backend.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace raybundle::visibility {

// Sorts `keys` by their bits at and above `low` (the bits below it are ignored: keys
// that agree above it keep no particular order), least significant digit first.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint64_t>& tmp, int low);

struct PairCountScratch {
    std::vector<std::uint64_t> keys, tmp;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> wide;  // pairs too wide to pack
};

// pairs: receiver << 32 | source, one per pixel (reordered; `tmp` is the sort's second
// buffer). Appends one entry per distinct pair to `out`: its pixel count times
// pixel_area.
void entries_from_pairs(std::vector<std::uint64_t>& pairs, std::vector<std::uint64_t>& tmp, double pixel_area,
                        std::vector<TransferEntry>& out);

// words: m records of three 32-bit words (receiver, source, count), each pair once.
// out.entries: one entry per record, sorted by (receiver, source), area = count *
// pixel_area.
void entries_from_counts(const std::uint32_t* words, std::uint32_t m, double pixel_area, PairCountScratch& scratch,
                         std::vector<TransferEntry>& out);

// The same through the wide records whatever the widths (for tests).
void entries_from_counts_wide(const std::uint32_t* words, std::uint32_t m, double pixel_area,
                              PairCountScratch& scratch, std::vector<TransferEntry>& out);

}  // namespace raybundle::visibility
