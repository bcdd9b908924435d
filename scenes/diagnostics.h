#pragma once
// Checks of a scene's geometry that no single patch shows.
#include "scenes/scene.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace raybundle::scenes {

// Pairs of patches in one plane, facing the same way, whose interiors overlap (a
// decal laid exactly onto a wall, a mesh imported twice). No visibility map can tell
// which of the two is in front: the backends put the higher patch index in front. Planes match
// within 1e-9 of the scene's radius; overlaps count from 1e-6 of the smaller area.
struct CoplanarOverlaps {
    std::size_t pairs = 0;
    std::uint32_t first = 0, second = 0;  // one of them (patch indices), when pairs > 0
    std::size_t listings = 0;             // the grid's (cell, patch) entries: the search's size
};
CoplanarOverlaps coplanar_overlaps(const Scene& scene, int threads = 1);  // the same for any thread count


}  // namespace raybundle::scenes
