#include "visibility/painter.h"

#include "visibility/centre_sort.h"
#include "visibility/raster.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace raybundle::visibility {

namespace {

// Sets row[0, n) to v. Runs are short (a few pixels), so instead of a loop with a
// data-dependent trip count: two overlapping fixed-width stores cover 4..16 pixels.
inline void fill_run(std::int32_t* row, int n, std::int32_t v) {
    const std::int32_t pattern[8] = {v, v, v, v, v, v, v, v};
    if (n >= 8) {
        for (int i = 0; i + 8 < n; i += 8) std::memcpy(row + i, pattern, sizeof pattern);
        std::memcpy(row + n - 8, pattern, sizeof pattern);
    } else if (n >= 4) {
        std::memcpy(row, pattern, 4 * sizeof(std::int32_t));
        std::memcpy(row + n - 4, pattern, 4 * sizeof(std::int32_t));
    } else {
        for (int i = 0; i < n; ++i) row[i] = v;
    }
}

}  // namespace

PainterBackend::PainterBackend(const scenes::Scene& scene, const BackendOptions& options,
                               std::shared_ptr<const PatchArrays> arrays)
    : arrays_(patch_arrays(scene, std::move(arrays))),
      grid_(scene, arrays_, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter),
      sky_(options.sky) {
    counts_.assign(scene.patch_count() + 2, 0);
}

void PainterBackend::transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = direction;
    out.entries.clear();
    grid_.project(direction, jitter);
    const int W = grid_.width();
    const double pixel_area = grid_.pixel_area();
    const Vec3 center = grid_.center();
    const double radius = grid_.radius();

    // Upstream (where the light comes from) first, by the patches' centres.
    const auto& normals = arrays_->normals;
    const std::size_t n = normals.size();
    side_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double facing = normals[i].dot(direction);
        side_[i] = facing > 0.0 ? 1 : (facing < 0.0 ? -1 : 0);
    }
    sort_by_centre(direction, normals, arrays_->centroids, center, radius, keys_, scratch_);

    const auto open_sky = static_cast<std::int32_t>(n);
    map_.assign(static_cast<std::size_t>(W) * W, sky_ ? open_sky : -1);
    std::int32_t* map = map_.data();
    for (const std::uint64_t key : keys_) {
        const std::uint32_t i = sorted_patch(key);
        const int side = side_[i];
        double X[3], Y[3];
        grid_.triangle(i, X, Y);
        if (side > 0) {
            // A source: it is what the next receiver downstream sees.
            const std::int32_t id = static_cast<std::int32_t>(i);
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                fill_run(map + static_cast<std::size_t>(y) * W + x0, x1 - x0, id);
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
            if (side < 0) {
                for (std::uint32_t j : touched_)
                    out.entries.push_back({i, j, counts_[j] * pixel_area});
            }
            for (std::uint32_t j : touched_) counts_[j] = 0;
            touched_.clear();
        }
    }
    if (sky_) {
        // Sources nothing covers downstream: along -w they see the open sky.
        for (std::size_t p = 0; p < map_.size(); ++p) {
            const std::int32_t j = map[p];
            if (j >= 0 && j < open_sky) {
                if (counts_[j] == 0) touched_.push_back(static_cast<std::uint32_t>(j));
                ++counts_[j];
            }
        }
        std::sort(touched_.begin(), touched_.end());
        for (std::uint32_t j : touched_) {
            out.entries.push_back({static_cast<std::uint32_t>(n + 1), j, counts_[j] * pixel_area});
            counts_[j] = 0;
        }
        touched_.clear();
    }
}

GouraudPainter::GouraudPainter(const scenes::Scene& scene, const BackendOptions& options,
                               std::shared_ptr<const PatchArrays> arrays)
    : arrays_(patch_arrays(scene, std::move(arrays))),
      grid_(scene, arrays_, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter) {}

void GouraudPainter::transfer(const Vec3& w, const Eigen::Vector2d& jitter, const std::vector<scenes::Rgb>& corner_out,
                              const scenes::Rgb& sky, std::vector<scenes::Rgb>& corner_in) {
    using scenes::Rgb;
    grid_.project(w, jitter);
    const int W = grid_.width();
    const auto& normals = arrays_->normals;
    const std::size_t n = normals.size();
    sort_by_centre(w, normals, arrays_->centroids, grid_.center(), grid_.radius(), keys_, scratch_);
    map_.assign(static_cast<std::size_t>(W) * W, sky);
    corner_in.assign(3 * n, Rgb::Zero());
    const double S = kSubpixel, H = 0.5 * kSubpixel;
    const double pixel_area = grid_.pixel_area();
    for (const std::uint64_t key : keys_) {
        const std::uint32_t i = sorted_patch(key);
        const double facing = normals[i].dot(w);
        double X[3], Y[3];
        grid_.triangle(i, X, Y);
        // Barycentric coordinates as affine functions of the pixel centre (sub-pixels).
        const double det = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
        if (det == 0.0 || facing == 0.0) {
            // No pixels, or edge-on: it only blocks what it covers.
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                Rgb* row = map_.data() + static_cast<std::size_t>(y) * W;
                std::fill(row + x0, row + x1, Rgb::Zero());
            });
            continue;
        }
        const double a1x = (Y[2] - Y[0]) / det, a1y = -(X[2] - X[0]) / det;
        const double a2x = -(Y[1] - Y[0]) / det, a2y = (X[1] - X[0]) / det;
        auto lambda = [&](double px, double py, double& l1, double& l2) {
            l1 = a1x * (px - X[0]) + a1y * (py - Y[0]);
            l2 = a2x * (px - X[0]) + a2y * (py - Y[0]);
        };
        if (facing > 0.0) {
            // A source: Gouraud-interpolate its corners' radiance.
            const Rgb& c0 = corner_out[3 * i];
            const Rgb d1 = corner_out[3 * i + 1] - c0, d2 = corner_out[3 * i + 2] - c0;
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                Rgb* row = map_.data() + static_cast<std::size_t>(y) * W;
                double l1, l2;
                lambda(x0 * S + H, y * S + H, l1, l2);
                for (int x = x0; x < x1; ++x, l1 += a1x * S, l2 += a2x * S) row[x] = c0 + l1 * d1 + l2 * d2;
            });
        } else {
            // A receiver: hat-weighted reads, then block.
            Rgb sum[3] = {Rgb::Zero(), Rgb::Zero(), Rgb::Zero()};
            rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
                Rgb* row = map_.data() + static_cast<std::size_t>(y) * W;
                double l1, l2;
                lambda(x0 * S + H, y * S + H, l1, l2);
                for (int x = x0; x < x1; ++x, l1 += a1x * S, l2 += a2x * S) {
                    const Rgb L = row[x];
                    row[x] = Rgb::Zero();
                    // Pixel centres lie inside the snapped triangle: lambdas in [0, 1] up to rounding.
                    const double b1 = std::clamp(l1, 0.0, 1.0), b2 = std::clamp(l2, 0.0, 1.0 - b1);
                    sum[0] += (1.0 - b1 - b2) * L;
                    sum[1] += b1 * L;
                    sum[2] += b2 * L;
                }
            });
            for (int k = 0; k < 3; ++k) corner_in[3 * i + k] = pixel_area * sum[k];
        }
    }
}

}  // namespace raybundle::visibility
