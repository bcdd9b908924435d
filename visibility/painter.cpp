#include "visibility/painter.h"

#include "sampling/directions.h"
#include "visibility/raster.h"

#include <algorithm>
#include <cmath>

namespace raybundle::visibility {

PainterBackend::PainterBackend(const scenes::Scene& scene, const BackendOptions& options)
    : resolution_(options.resolution > 0 ? options.resolution : default_resolution(scene)),
      jitter_(options.jitter),
      center_(scene.bounds_center()),
      radius_(scene.bounds_radius()),
      positions_(scene.vertex_positions()) {
    const auto& patches = scene.patch_list();
    indices_.reserve(3 * patches.size());
    for (const auto& p : patches) {
        for (int k : p.v) indices_.push_back(static_cast<std::uint32_t>(k));
        normals_.push_back(p.normal);
        centroids_.push_back(p.centroid);
    }
    counts_.assign(patches.size(), 0);
}

void PainterBackend::transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = direction;
    out.entries.clear();
    const int W = resolution_ + 1;  // one spare pixel for the jitter shift
    const double pixel = 2.0 * radius_ / resolution_;
    const double pixel_area = pixel * pixel;
    const double jx = jitter_ ? jitter.x() : 0.5, jy = jitter_ ? jitter.y() : 0.5;

    // Project every vertex onto the plane perpendicular to w, in snapped sub-pixel units.
    Vec3 u, v;
    sampling::orthonormal_basis(direction, u, v);
    const double scale = kSubpixel / pixel;
    const std::size_t nv = positions_.size();
    px_.resize(nv);
    py_.resize(nv);
    for (std::size_t k = 0; k < nv; ++k) {
        const Vec3 d = positions_[k] - center_;
        px_[k] = std::nearbyint((u.dot(d) + radius_) * scale + jx * kSubpixel);
        py_[k] = std::nearbyint((v.dot(d) + radius_) * scale + jy * kSubpixel);
    }

    // Sort along w: upstream (where the light comes from) first. Depth is measured from
    // the scene's centre in double precision; at equal depth receivers go first, so a
    // two-sided panel made of two coincident opposite triangles does not leak light.
    const std::size_t n = normals_.size();
    order_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t source = normals_[i].dot(direction) > 0.0 ? 1 : 0;
        order_[i] = {direction.dot(centroids_[i] - center_), (source << 32) | i};
    }
    std::sort(order_.begin(), order_.end());

    map_.assign(static_cast<std::size_t>(W) * W, -1);
    std::int32_t* map = map_.data();
    for (const auto& [key, tag] : order_) {
        const auto i = static_cast<std::uint32_t>(tag & 0xFFFFFFFFu);
        const double facing = normals_[i].dot(direction);
        const std::uint32_t* tri = &indices_[3 * i];
        const double X[3] = {px_[tri[0]], px_[tri[1]], px_[tri[2]]};
        const double Y[3] = {py_[tri[0]], py_[tri[1]], py_[tri[2]]};
        if (facing > 0.0) {
            // A source: it is what the next receiver downstream sees.
            const std::int32_t id = static_cast<std::int32_t>(i);
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                std::fill(map + static_cast<std::size_t>(y) * W + x0, map + static_cast<std::size_t>(y) * W + x1, id);
            });
        } else {
            // A receiver (or edge-on): read what it sees, then block everything behind it.
            // Consecutive pixels mostly see the same source: count runs, and touch the
            // per-source counters only where the source changes.
            std::int32_t current = -1;
            std::uint32_t run = 0;
            auto flush = [&]() {
                if (current >= 0 && run > 0) {
                    if (counts_[current] == 0) touched_.push_back(static_cast<std::uint32_t>(current));
                    counts_[current] += run;
                }
            };
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                std::int32_t* row = map + static_cast<std::size_t>(y) * W;
                for (int x = x0; x < x1; ++x) {
                    const std::int32_t j = row[x];
                    row[x] = -1;
                    if (j != current) {
                        flush();
                        current = j;
                        run = 0;
                    }
                    ++run;
                }
            });
            flush();
            if (facing < 0.0) {
                for (std::uint32_t j : touched_)
                    out.entries.push_back({i, j, counts_[j] * pixel_area});
            }
            for (std::uint32_t j : touched_) counts_[j] = 0;
            touched_.clear();
        }
    }
}

}  // namespace raybundle::visibility
