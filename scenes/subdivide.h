#pragma once
#include "scenes/scene.h"

#include <string>

namespace raybundle::scenes {

// Refines the scene by conforming longest-edge bisection until no edge is longer
// than max_edge. Each split halves an edge at its midpoint and both triangles on it,
// so the mesh stays watertight (no T-junctions) and triangles keep their shape
// class. Materials are copied to the new faces; the corner normals are carried (the
// new vertex of a split edge gets, in each face, the normalised mean of that face's
// normals at the edge's ends), so call scene.finalize() first, which computes the
// missing ones on the coarse patches. Calls scene.finalize() at the end.
// Returns the number of splits.
std::size_t subdivide(Scene& scene, double max_edge);

// Splits the edge of halfedge h at from + t (to - from), 0 < t < 1, and the faces on
// both sides of it (conforming), carrying the corner normals as subdivide() does (the
// new vertex's: the normalised blend at t) and the contact mark of the edge to both of
// its halves. Returns the new vertex. The flat arrays
// are stale until scene.finalize().
TriMesh::VertexHandle split_edge(Scene& scene, TriMesh::HalfedgeHandle h, double t);

// Refinement to max_edge leaves triangles of at least about max_edge^2 / 4 area, and
// cuts a sliver along all of its longest edge: throws SceneError (naming `shown`) when
// the larger of the two counts, summed over the triangles, passes `max_patches` (20
// million by default: more than any run can hold), or when max_edge is not a positive
// number.
inline constexpr double kMaxPatches = 2e7;
void check_refinement(const Scene& scene, double max_edge, const std::string& shown, double max_patches = kMaxPatches);

}  // namespace raybundle::scenes
