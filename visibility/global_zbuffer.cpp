#include "visibility/global_zbuffer.h"

#include "visibility/pixel_pairs.h"

#include <algorithm>

namespace raybundle::visibility {

GlobalZBufferBackend::GlobalZBufferBackend(const scenes::Scene& scene, const BackendOptions& options,
                                           std::shared_ptr<const PatchArrays> arrays)
    : arrays_(patch_arrays(scene, std::move(arrays))),
      grid_(scene, arrays_, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter),
      sky_(options.sky) {}

void GlobalZBufferBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    grid_.project(w, jitter);
    const int W = grid_.width();
    const auto& normals = arrays_->normals;
    const auto& plane = arrays_->offsets;  // n . p0 per patch
    const std::size_t n = normals.size();

    // Pass 1: fragments per pixel; then offsets by prefix sum.
    offsets_.assign(static_cast<std::size_t>(W) * W + 1, 0);
    std::uint32_t* count = offsets_.data() + 1;
    double X[3], Y[3];
    for (std::uint32_t i = 0; i < n; ++i) {
        if (normals[i].dot(w) == 0.0) continue;  // edge-on: no projected area, blocks nothing
        grid_.triangle(i, X, Y);
        rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
            std::uint32_t* row = count + static_cast<std::size_t>(y) * W;
            for (int x = x0; x < x1; ++x) ++row[x];
        });
    }
    for (std::size_t k = 1; k < offsets_.size(); ++k) offsets_[k] += offsets_[k - 1];

    // Pass 2: each patch's depth along w at the pixel centres it covers. The pixel's ray
    // is q + t w (q on the map plane); the patch plane n . x = c meets it at
    // t = (c - n . q) / (n . w), and the depth is w . q + t = t (w . q = w . centre).
    fragments_.resize(offsets_.back());
    std::vector<std::uint32_t>& fill = offsets_;  // advanced to each pixel's end, then restored
    const Vec3 origin = grid_.pixel_point(0, 0);
    const Vec3 du = grid_.pixel_point(1, 0) - origin, dv = grid_.pixel_point(0, 1) - origin;
    for (std::uint32_t i = 0; i < n; ++i) {
        const double nw = normals[i].dot(w);
        if (nw == 0.0) continue;  // skipped in pass 1 too
        grid_.triangle(i, X, Y);
        // t(x, y) = t0 + tx x + ty y
        const double t0 = (plane[i] - normals[i].dot(origin)) / nw;
        const double tx = -normals[i].dot(du) / nw, ty = -normals[i].dot(dv) / nw;
        const bool source = nw > 0.0;
        rasterize_triangle(X, Y, W, W, [&](int y, int x0, int x1) {
            const std::size_t row = static_cast<std::size_t>(y) * W;
            for (int x = x0; x < x1; ++x)
                fragments_[fill[row + x]++] = {t0 + tx * x + ty * y, i, source};
        });
    }
    for (std::size_t k = offsets_.size() - 1; k > 0; --k) offsets_[k] = offsets_[k - 1];
    offsets_[0] = 0;

    // Per pixel: sort by depth (lists are short), then pair each source with the patch
    // right behind it when that one is a receiver.
    pairs_.clear();
    const double tie = 1e-9 * grid_.radius();
    for (std::size_t p = 0; p + 1 < offsets_.size(); ++p) {
        Fragment* first = fragments_.data() + offsets_[p];
        Fragment* last = fragments_.data() + offsets_[p + 1];
        if (last - first < (sky_ ? 1 : 2)) continue;
        // Insertion sort by depth; then ties ordered as in every backend.
        auto before = [](const Fragment& a, const Fragment& b) {
            return a.depth < b.depth || (a.depth == b.depth && !a.source && b.source);
        };
        for (Fragment* f = first + 1; f < last; ++f)
            for (Fragment* g = f; g > first && before(*g, g[-1]); --g) std::swap(*g, g[-1]);
        order_ties(first, last, tie, [](const Fragment& f) { return f.depth; },
                   [](const Fragment& f) { return f.source; }, [](const Fragment& f) { return f.patch; });
        pairs_along(first, last, [](const Fragment& f) { return f.patch; }, [](const Fragment& f) { return f.source; },
                    sky_, static_cast<std::uint32_t>(n),
                    [&](std::uint32_t r, std::uint32_t src) { pairs_.push_back(pixel_pair(r, src)); });
    }

    // One entry per (receiver, source).
    entries_from_pairs(pairs_, sort_, grid_.pixel_area(), out.entries);
}

}  // namespace raybundle::visibility
