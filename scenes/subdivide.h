#pragma once
#include "scenes/scene.h"

namespace raybundle::scenes {

// Refines the scene by conforming longest-edge bisection until no edge is longer
// than max_edge. Each split halves an edge at its midpoint and both triangles on it,
// so the mesh stays watertight (no T-junctions) and triangles keep their shape
// class. Materials are copied to the new faces. Calls scene.finalize().
// Returns the number of splits.
std::size_t subdivide(Scene& scene, double max_edge);

}  // namespace raybundle::scenes
