#pragma once
// Hardware z-buffer visibility through OpenGL 4.5 (004 section 5.1.4's idea, done by
// depth peeling), exact: the same matrix as the global z-buffer, drawn by the GPU.
//
// Parameters (BackendOptions): resolution (int, pixels per side of the same jittered
// grid as the other discrete backends; default: default_resolution(scene)), jitter
// (bool, default true), sky (bool).
//
// Per direction:
//   1. The vertices are projected on the CPU by MapGrid (the grid every discrete backend
//      uses: positions snapped to 1/256 pixel, which a GPU's rasteriser keeps exactly).
//   2. Depth peeling finds every patch over every pixel centre: pass k keeps, per pixel,
//      the least (float depth, patch id) after layer k - 1's, so coincident surfaces
//      (a two-sided panel, touching blocks) come out one layer each instead of merging.
//      A compute pass copies each layer's patch ids into a buffer of layers.
//   3. A compute pass per pixel re-orders its layers by the patches' exact depths at
//      the pixel centre, in double precision from the same plane coefficients as the
//      global z-buffer, ties ordered as by every backend (pixel_pairs.h), and pairs each
//      source with the receiver behind it (and the sky, when asked for). The float
//      depths only drive the peeling; the order is the exact one.
//   4. The pairs are counted on the GPU in a hash table (two 32-bit keys claimed by
//      compare-and-swap, a count added atomically); only the distinct pairs, their
//      count and the table's used slots come back over the bus: thousands of entries,
//      not megapixels. The CPU sorts them by (receiver, source): the same entries in
//      the same order for any GPU scheduling.
// Layers are drawn in batches sized by the previous direction's depth complexity, with
// one wait for the GPU per batch, one for the pair count and one for the entries.
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
    // The OpenGL implementation in use.
    std::string details() const override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace raybundle::visibility
