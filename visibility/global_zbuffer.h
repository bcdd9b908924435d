#pragma once
// The software global z-buffer (004 section 5.1.5).
//
// Parameters (BackendOptions): resolution (int, pixels per side; default:
// default_resolution(scene)), jitter (bool, default true).
//
// Every patch is scan-converted into the same jittered grid as the painter's, but a
// pixel keeps the list of all patches over it with their exact depths along w at the
// pixel centre. Each list is sorted by depth, and every source directly followed by a
// receiver adds one pixel's area to A(receiver, source). The order is exact per pixel,
// so interpenetrating or overlapping patches, where sorting by centres fails, come out
// right. Costs about twice the painter's rasterisation plus the per-pixel sorts.
#include "visibility/backend.h"
#include "visibility/map_grid.h"
#include "visibility/patch_arrays.h"

#include <cstdint>
#include <vector>

namespace raybundle::visibility {

class GlobalZBufferBackend final : public Backend {
public:
    // `arrays`: shared with the other backends of a set (made here where none is given).
    GlobalZBufferBackend(const scenes::Scene& scene, const BackendOptions& options,
                         std::shared_ptr<const PatchArrays> arrays = nullptr);
    std::string name() const override { return "global-zbuffer"; }
    int resolution() const override { return grid_.resolution(); }
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;

private:
    struct Fragment {
        double depth;        // w . x at the pixel centre
        std::uint32_t patch;
        bool source;         // faces w
    };

    std::shared_ptr<const PatchArrays> arrays_;  // read only
    MapGrid grid_;
    bool sky_;

    // Scratch, reused between directions.
    std::vector<std::uint32_t> offsets_;
    std::vector<Fragment> fragments_;
    std::vector<std::uint64_t> pairs_;  // receiver << 32 | source, one per pixel
    std::vector<std::uint64_t> sort_;   // the sort's second buffer
};

}  // namespace raybundle::visibility
