#pragma once
// The scene's patches as flat arrays, as the pixel backends read them: the vertices,
// each patch's corners, normal, centre and plane. Made once per set of backends
// (BackendSet, or make_backend for a backend alone) and shared, read only, by the
// backends of all its threads: every backend held a copy before (12.6 MB each at
// 121,324 patches, twice the vertices and corners: its own and its map grid's).
#include "scenes/scene.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace raybundle::visibility {

struct PatchArrays {
    explicit PatchArrays(const scenes::Scene& scene) : positions(scene.vertex_positions()) {
        const auto& list = scene.patch_list();
        corners.reserve(3 * list.size());
        normals.reserve(list.size());
        centroids.reserve(list.size());
        offsets.reserve(list.size());
        for (const auto& p : list) {
            for (int k : p.v) corners.push_back(static_cast<std::uint32_t>(k));
            normals.push_back(p.normal);
            centroids.push_back(p.centroid);
            offsets.push_back(p.normal.dot(positions[p.v[0]]));
        }
    }
    std::size_t patches() const { return normals.size(); }

    std::vector<scenes::Vec3> positions;   // the scene's vertices
    std::vector<std::uint32_t> corners;    // 3 vertex indices per patch
    std::vector<scenes::Vec3> normals;     // unit, per patch
    std::vector<scenes::Vec3> centroids;   // per patch
    std::vector<double> offsets;           // n . p0 per patch: its plane n . x = offset
};

// `given` where there is one (a set's, shared), else the scene's own.
inline std::shared_ptr<const PatchArrays> patch_arrays(const scenes::Scene& scene,
                                                       std::shared_ptr<const PatchArrays> given = nullptr) {
    return given ? std::move(given) : std::make_shared<const PatchArrays>(scene);
}

}  // namespace raybundle::visibility
