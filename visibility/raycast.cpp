#include "visibility/raycast.h"

#include "visibility/pixel_pairs.h"

#include <algorithm>

namespace raybundle::visibility {

RaycastBackend::RaycastBackend(const scenes::Scene& scene, const BackendOptions& options,
                               std::shared_ptr<const PatchArrays> arrays)
    : arrays_(patch_arrays(scene, std::move(arrays))),
      grid_(scene, arrays_, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter),
      sky_(options.sky),
      caster_(scene) {}

void RaycastBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    grid_.project(w, jitter);
    const int W = grid_.width();
    const double R = grid_.radius();
    const Vec3 center = grid_.center();
    const auto& normals = arrays_->normals;
    pairs_.clear();
    for (int y = 0; y < W; ++y)
        for (int x = 0; x < W; ++x) {
            const Vec3 q = grid_.pixel_point(x, y);
            if ((q - center).squaredNorm() > R * R) continue;  // misses the bounding sphere
            // From upstream of the whole scene to downstream of it.
            caster_.all_hits(q - 1.01 * R * w, w, hits_, 0.0, 2.02 * R);
            // At equal distance (up to Embree's float precision) ties are ordered as in the
            // other backends: a two-sided panel does not leak.
            order_ties(hits_.begin(), hits_.end(), 1e-6 * R, [](const scenes::RayHit& h) { return h.t; },
                       [&](const scenes::RayHit& h) { return normals[h.patch].dot(w) > 0.0; },
                       [](const scenes::RayHit& h) { return h.patch; });
            pairs_along(hits_.begin(), hits_.end(), [](const scenes::RayHit& h) { return h.patch; },
                        [&](const scenes::RayHit& h) { return normals[h.patch].dot(w) > 0.0; }, sky_,
                        static_cast<std::uint32_t>(normals.size()),
                        [&](std::uint32_t r, std::uint32_t src) { pairs_.push_back(pixel_pair(r, src)); });
        }
    entries_from_pairs(pairs_, sort_, grid_.pixel_area(), out.entries);
}

}  // namespace raybundle::visibility
