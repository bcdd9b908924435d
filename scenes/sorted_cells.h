#pragma once
// A hashed grid as runs of a sorted array, for the searches that pair triangles near
// one another (the contact search, the coplanar overlaps).
#include "scenes/buffer.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace raybundle::scenes {

// Every (cell, item) listing in item order, sorted by cell stably (so a cell's items
// stay in index order) by an LSD radix sort whose passes split the array into fixed
// chunks on the threads (the same order for any count); each listing then knows its
// cell's run. listed[i]: the cells item i meets, as 64-bit keys.
struct SortedCells {
    std::vector<std::size_t> first;       // item i's listings: first[i] .. first[i + 1]
    // (filled on the threads: see scenes/buffer.h)
    Buffer<std::uint32_t> run_of;         // per listing, its cell's run
    Buffer<std::size_t> run_start;        // run r: members[run_start[r] .. run_start[r + 1]]
    Buffer<std::uint32_t> members;        // the items of each cell, in index order

    SortedCells(const std::vector<std::vector<std::uint64_t>>& listed, int threads);
};

}  // namespace raybundle::scenes
