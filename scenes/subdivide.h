#pragma once
#include "scenes/machine.h"
#include "scenes/scene.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::scenes {

// Refines the scene by conforming longest-edge bisection until no edge is longer
// than max_edge. Each split halves an edge at its midpoint and both triangles on it,
// so the mesh stays watertight (no T-junctions) and triangles keep their shape
// class. Materials are copied to the new faces; the corner normals are carried (the
// new vertex of a split edge gets, in each face, the normalised mean of that face's
// normals at the edge's ends), so call scene.finalize() first, which computes the
// missing ones on the coarse patches. Each pass splits every edge longer than max_edge,
// longest first; the mesh is exactly what split_edge() on each in that order makes (the
// same handles), the splits of a pass that share no face or boundary link running on the
// threads (the same mesh for any count). Calls scene.finalize(threads) at the end, or with
// Finish::leave_mesh leaves that to the caller (cut_at_contacts() does it): the mesh is
// refined, the flat arrays (patch_list() and the rest) still the coarse scene's, its
// bounds unchanged by midpoints. Returns the number of splits.
// Before each pass the patches it will leave are known exactly: where they pass
// `max_patches`, subdivide() throws PatchLimit with that count, the scene untouched
// (the passes work on a copy of the mesh, written back at the end).
enum class Finish { finalize, leave_mesh };
inline constexpr double kMaxPatches = 2e7;
struct PatchLimit : std::runtime_error {
    explicit PatchLimit(std::size_t patches);
    std::size_t patches;  // after the pass that would have passed the limit: at least this many
};
std::size_t subdivide(Scene& scene, double max_edge, int threads = 1, Finish finish = Finish::finalize,
                      double max_patches = kMaxPatches);

// Refines chosen patches: patch i (scene.patch_list() order) is cut until no piece of it
// has an edge longer than max_edge[i] (infinity, or any value at least its longest edge:
// not cut for itself, only where conformity with a neighbour's cut asks). The cuts are conforming longest-edge bisections after Rivara's LEPP:
// an edge is split only where it is the longest edge of both triangles on it, so where
// it is not, the neighbour's longest edge is split first. The mesh stays watertight,
// the angles stay bounded (the smallest at least half of the coarse mesh's), and the
// neighbours of a cut patch are split only as far as conformity asks. Materials,
// objects, corner normals and contact marks are carried as subdivide() carries them.
// `origin`, when given, receives for every patch of the refined scene the index of the
// patch it is part of. Calls scene.finalize(threads). Returns the number of splits.
// Throws std::invalid_argument when max_edge has not one entry per patch, or one is not
// a positive number.
std::size_t refine_patches(Scene& scene, const std::vector<double>& max_edge, std::vector<std::uint32_t>* origin = nullptr,
                           int threads = 1);

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
// number. The count is a lower bound (refinement leaves max_edge^2 / 6 on average): a
// scene it lets through may still be stopped by subdivide()'s exact count, a pass in.
// The limit is a PatchBudget: max_patches, or fewer where the memory of the process
// (its share of the machine's among MPI ranks: scenes/machine.h) holds fewer while the
// scene is prepared, at kPreparationBytes a
// patch (the peak resident memory of `raybundle check` on a scene in millimetres refined
// to 1.3 and 5.1 million patches: 0.83 and 1.13 KB a patch). Its `why` ends the error.
inline constexpr double kPreparationBytes = 1200.0;
struct PatchBudget {
    double patches;
    std::string why;  // "limit 20,000,000", or the memory's reason
};
PatchBudget patch_budget(double max_patches = kMaxPatches, const MemoryShare& memory = memory_share());
void check_refinement(const Scene& scene, double max_edge, const std::string& shown, const PatchBudget& budget);

// check_refinement(), then subdivide(), its PatchLimit thrown as SceneError naming
// `shown`: "patch_size: 0.5 makes 20,312,448 patches or more (limit 20,000,000)".
std::size_t refine_within(Scene& scene, double max_edge, const std::string& shown, const PatchBudget& budget,
                          int threads = 1, Finish finish = Finish::finalize);

}  // namespace raybundle::scenes
