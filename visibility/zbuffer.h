#pragma once
// Hardware z-buffer visibility through OpenGL 4.5 (004 section 5.1.4's idea): the GPU
// rasterises, orders and pairs. Exact: the global z-buffer's matrix, up to which of two
// triangles owns a pixel centre lying exactly on their shared edge (the rasteriser's
// rule rather than raster.h's).
//
// Parameters (BackendOptions): resolution (int, pixels per side of the same jittered
// grid as the other discrete backends; default: default_resolution(scene)), jitter
// (bool, default true), sky (bool).
//
// Per direction:
//   1. The vertices are projected on the CPU by MapGrid (the grid every discrete backend
//      uses: positions snapped to 1/256 pixel, which a GPU's rasteriser keeps exactly
//      through a power-of-two viewport), and each patch's depth plane over the map is
//      written as the global z-buffer computes it (double precision).
//   2. One draw of all patches without a depth test: every fragment of a patch that is
//      not edge-on appends the patch to its pixel's list (a per-pixel count, the k-th
//      arrival in layer k of a buffer).
//      Depth peeling would need a draw and a read per layer, and float depths that merge
//      coincident surfaces; the lists keep all of them.
//   3. A compute pass per pixel orders its list by the patches' exact depths at the
//      pixel centre, ties as by every backend (pixel_pairs.h), and pairs each source with
//      the receiver behind it (and the sky, when asked for). Each 16 x 16 tile counts its
//      pairs in shared memory, then adds them to a global hash table (two 32-bit keys
//      claimed by compare-and-swap, a count added atomically).
//   4. A one-thread pass sizes the compaction, which copies the table's used slots into
//      a read-back buffer and clears them. One wait for the GPU (reading the entry
//      count), then only the distinct pairs cross the bus: thousands of entries rather
//      than megapixels. The CPU sorts them by (receiver, source): the same entries in
//      the same order whatever the GPU's scheduling.
// Batches (transfer_many(), what the solvers call through BackendSet): many directions
// in one submission, each with slots of its own for its vertices, depth records and
// read-back part, one after another on the GPU (every pass leaves the lists and the
// table clean for the next); the CPU's preparation and sorting on the caller's threads,
// and the solver's own work while the GPU draws.
// A pixel with more surfaces than the layer buffer holds, or a crowded table, grows the
// buffer and runs the direction again (rare after the first directions). More than 64
// surfaces over one pixel, more layers than one buffer of the GPU holds, or a table
// past 2^28 slots is an error that names exact-painter.
//
// RAYBUNDLE_ZBUFFER_PROFILE=1 prints the CPU and GPU milliseconds per stage to stderr
// when the backend is destroyed.
//
// The OpenGL context comes from gl_context.h (OSMesa by default, EGL on a GPU).
#include "visibility/backend.h"

#include <memory>

namespace raybundle::visibility {

class ZBufferBackend final : public Backend {
public:
    ZBufferBackend(const scenes::Scene& scene, const BackendOptions& options);
    ~ZBufferBackend() override;
    std::string name() const override { return "zbuffer"; }
    int resolution() const override;
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;
    // Up to 16 directions per submission (fewer where their buffers would pass 256 MiB):
    // their vertices and depth records prepared on the threads, all drawn, paired and
    // compacted in one go, `alongside` run while the GPU works, one wait, the entries
    // sorted on the threads. The same matrices as transfer().
    void transfer_many(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                       std::vector<GeometryMatrix>& out, int threads, const std::function<void()>& alongside) override;
    int batch_directions() const override;
    // The OpenGL implementation in use.
    std::string details() const override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace raybundle::visibility
