#pragma once
// Ray-casting visibility through Embree: an independent second reference for the
// discrete backends, and the ray-casting layer the final gather shares.
//
// Parameters (BackendOptions): resolution (int, rays per side of the same jittered
// grid the painter's uses; default: default_resolution(scene)), jitter (bool, default
// true).
//
// One ray along w through every pixel centre of the grid that lies inside the scene's
// bounding disc; all of its crossings with patches, in order along the ray; every
// source directly followed by a receiver adds one pixel's area to A(receiver, source).
// Exact order per ray, like the global z-buffer, but by an independent code path
// (Embree's BVH and its float ray-triangle tests). Slow: one traced ray per pixel.
#include "scenes/ray_caster.h"
#include "visibility/backend.h"
#include "visibility/map_grid.h"
#include "visibility/patch_arrays.h"

#include <cstdint>
#include <vector>

namespace raybundle::visibility {

class RaycastBackend final : public Backend {
public:
    // `arrays`: shared with the other backends of a set (made here where none is given).
    RaycastBackend(const scenes::Scene& scene, const BackendOptions& options,
                   std::shared_ptr<const PatchArrays> arrays = nullptr);
    std::string name() const override { return "raycast"; }
    int resolution() const override { return grid_.resolution(); }
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;

private:
    std::shared_ptr<const PatchArrays> arrays_;  // read only
    MapGrid grid_;
    bool sky_;
    scenes::RayCaster caster_;

    // Scratch, reused between directions.
    std::vector<scenes::RayHit> hits_;
    std::vector<std::uint64_t> pairs_;  // receiver << 32 | source, one per ray
    std::vector<std::uint64_t> sort_;   // the sort's second buffer
};

}  // namespace raybundle::visibility
