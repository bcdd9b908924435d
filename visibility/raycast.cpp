#include "visibility/raycast.h"

#include "visibility/pixel_pairs.h"

#include <algorithm>

namespace raybundle::visibility {

RaycastBackend::RaycastBackend(const scenes::Scene& scene, const BackendOptions& options)
    : grid_(scene, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter),
      sky_(options.sky),
      caster_(scene) {
    for (const auto& p : scene.patch_list()) normals_.push_back(p.normal);
}

void RaycastBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    grid_.project(w, jitter);
    const int W = grid_.width();
    const double R = grid_.radius();
    const Vec3 center = grid_.center();
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
                       [&](const scenes::RayHit& h) { return normals_[h.patch].dot(w) > 0.0; },
                       [](const scenes::RayHit& h) { return h.patch; });
            for (std::size_t k = 0; k + 1 < hits_.size(); ++k) {
                const auto& a = hits_[k];
                const auto& b = hits_[k + 1];
                if (normals_[a.patch].dot(w) > 0.0 && normals_[b.patch].dot(w) < 0.0)
                    pairs_.push_back(pixel_pair(static_cast<std::uint32_t>(b.patch), static_cast<std::uint32_t>(a.patch)));
            }
            if (sky_ && !hits_.empty()) {
                const auto sky = static_cast<std::uint32_t>(normals_.size());
                const auto first = static_cast<std::uint32_t>(hits_.front().patch);
                const auto last = static_cast<std::uint32_t>(hits_.back().patch);
                if (normals_[first].dot(w) < 0.0) pairs_.push_back(pixel_pair(first, sky));
                if (normals_[last].dot(w) > 0.0) pairs_.push_back(pixel_pair(sky + 1, last));
            }
        }
    entries_from_pairs(pairs_, grid_.pixel_area(), out.entries);
}

}  // namespace raybundle::visibility
