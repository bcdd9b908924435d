#include "scenes/diagnostics.h"

#include "scenes/threads.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <utility>
#include <vector>

namespace raybundle::scenes {

namespace {

using P2 = Eigen::Vector2d;

double cross(const P2& a, const P2& b) { return a.x() * b.y() - a.y() * b.x(); }

// The area of the intersection of two triangles (Sutherland-Hodgman: clip one by the
// other's three edges, counter-clockwise).
double overlap_area(std::array<P2, 3> a, std::array<P2, 3> b) {
    auto ccw = [](std::array<P2, 3>& t) {
        if (cross(t[1] - t[0], t[2] - t[0]) < 0) std::swap(t[1], t[2]);
    };
    ccw(a);
    ccw(b);
    std::vector<P2> poly(a.begin(), a.end()), next;
    for (int e = 0; e < 3 && !poly.empty(); ++e) {
        const P2 p = b[e], q = b[(e + 1) % 3];
        next.clear();
        for (std::size_t k = 0; k < poly.size(); ++k) {
            const P2& s = poly[k];
            const P2& t = poly[(k + 1) % poly.size()];
            const double ds = cross(q - p, s - p), dt = cross(q - p, t - p);
            if (ds >= 0) next.push_back(s);
            if ((ds >= 0) != (dt >= 0)) next.push_back(s + (t - s) * (ds / (ds - dt)));
        }
        poly.swap(next);
    }
    double area = 0.0;
    for (std::size_t k = 0; k < poly.size(); ++k) area += cross(poly[k], poly[(k + 1) % poly.size()]);
    return 0.5 * area;
}

// The extent of a triangle along an axis.
std::pair<double, double> extent(const std::array<P2, 3>& t, const P2& axis) {
    const double a = axis.dot(t[0]), b = axis.dot(t[1]), c = axis.dot(t[2]);
    return {std::min({a, b, c}), std::max({a, b, c})};
}

// Whether two triangles' interiors are apart: an edge normal of one separates them
// (touching along it counts as apart), within 1e-12 of their size.
bool apart(const std::array<P2, 3>& a, const std::array<P2, 3>& b) {
    for (const auto* t : {&a, &b})
        for (int e = 0; e < 3; ++e) {
            const P2 d = (*t)[(e + 1) % 3] - (*t)[e], axis(-d.y(), d.x());
            const auto [a0, a1] = extent(a, axis);
            const auto [b0, b1] = extent(b, axis);
            const double slack = 1e-12 * d.squaredNorm();
            if (a1 <= b0 + slack || b1 <= a0 + slack) return true;
        }
    return false;
}

// Whether a triangle meets the closed square of side `side` at `corner` (separating
// axes: the square's two, then the triangle's three edge normals).
bool meets_square(const std::array<P2, 3>& t, const P2& corner, double side) {
    P2 lo = t[0], hi = t[0];
    for (const P2& c : t) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    if (hi.x() < corner.x() || lo.x() > corner.x() + side || hi.y() < corner.y() || lo.y() > corner.y() + side)
        return false;
    const std::array<P2, 4> square = {corner, corner + P2(side, 0), corner + P2(side, side), corner + P2(0, side)};
    for (int e = 0; e < 3; ++e) {
        const P2 d = t[(e + 1) % 3] - t[e], axis(-d.y(), d.x());
        const auto [a0, a1] = extent(t, axis);
        double b0 = axis.dot(square[0]), b1 = b0;
        for (const P2& c : square) b0 = std::min(b0, axis.dot(c)), b1 = std::max(b1, axis.dot(c));
        if (a1 < b0 || b1 < a0) return false;
    }
    return true;
}

}  // namespace

CoplanarOverlaps coplanar_overlaps(const Scene& scene, int threads) {
    CoplanarOverlaps result;
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const std::size_t n = patches.size();
    if (n < 2) return result;
    const double tol = 1e-9 * scene.bounds_radius();

    // Group by plane: the normal rounded to 1e-6, then the offset n . p within tol.
    struct Key {
        long long nx, ny, nz;
        double offset;
        std::uint32_t patch;
    };
    std::vector<Key> keys(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3& nrm = patches[i].normal;
        keys[i] = {std::llround(nrm.x() * 1e6), std::llround(nrm.y() * 1e6), std::llround(nrm.z() * 1e6),
                   nrm.dot(pos[patches[i].v[0]]), static_cast<std::uint32_t>(i)};
    }
    std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
        if (a.nx != b.nx) return a.nx < b.nx;
        if (a.ny != b.ny) return a.ny < b.ny;
        if (a.nz != b.nz) return a.nz < b.nz;
        return a.offset < b.offset;
    });

    std::vector<std::uint32_t> group;
    std::vector<std::array<P2, 3>> tri;
    std::vector<std::pair<P2, P2>> box;
    std::vector<std::vector<long long>> listed;  // each triangle's cells
    std::unordered_map<long long, std::vector<std::uint32_t>> cells;
    for (std::size_t g0 = 0; g0 < n;) {
        std::size_t g1 = g0 + 1;
        while (g1 < n && keys[g1].nx == keys[g0].nx && keys[g1].ny == keys[g0].ny && keys[g1].nz == keys[g0].nz &&
               keys[g1].offset - keys[g1 - 1].offset <= tol)
            ++g1;
        if (g1 - g0 >= 2) {
            // The group's patches in 2-D, in a uniform grid of cells about two patches wide.
            group.clear();
            tri.clear();
            cells.clear();
            const Vec3 normal = patches[keys[g0].patch].normal;
            const Vec3 u = normal.unitOrthogonal(), v = normal.cross(u);
            double area = 0.0;
            // In 2-D relative to the group's first corner (offsets far from the origin
            // keep their precision).
            const Vec3 origin = pos[patches[keys[g0].patch].v[0]];
            for (std::size_t k = g0; k < g1; ++k) {
                const Patch& p = patches[keys[k].patch];
                group.push_back(keys[k].patch);
                std::array<P2, 3> t;
                for (int c = 0; c < 3; ++c) t[c] = P2(u.dot(pos[p.v[c]] - origin), v.dot(pos[p.v[c]] - origin));
                tri.push_back(t);
                area += p.area;
            }
            // A uniform grid of cells about two patches wide; a triangle is listed in
            // the cells it meets, not in all its bounding box covers (a sliver across
            // the plane meets a line of cells, its box a square of them), and each
            // pair is tested once (the stamp says which triangle last took it).
            const double cell = 2.0 * std::sqrt(area / static_cast<double>(group.size()));
            const int m = static_cast<int>(group.size());
            // Large groups (a wall of many patches) on the threads, small ones on this one.
            const int T = m >= 4096 ? threads : 1;
            box.assign(group.size(), {});
            listed.assign(group.size(), {});
            parallel_bands(m, T, [&](int k0, int k1) {
                for (auto k = static_cast<std::uint32_t>(k0); k < static_cast<std::uint32_t>(k1); ++k) {
                    P2 lo = tri[k][0], hi = tri[k][0];
                    for (const P2& c : tri[k]) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
                    box[k] = {lo, hi};
                    const long long x0 = std::llround(std::floor(lo.x() / cell)), x1 = std::llround(std::floor(hi.x() / cell));
                    const long long y0 = std::llround(std::floor(lo.y() / cell)), y1 = std::llround(std::floor(hi.y() / cell));
                    for (long long x = x0; x <= x1; ++x)
                        for (long long y = y0; y <= y1; ++y)
                            if (meets_square(tri[k], P2(x * cell, y * cell), cell)) listed[k].push_back(x * 1000003LL + y);
                }
            });
            for (std::uint32_t k = 0; k < group.size(); ++k)
                for (const long long c : listed[k]) cells[c].push_back(k);
            // Bands of triangles on the threads, each with its own stamps; the pairs
            // sorted below whatever the split.
            const int bands = std::max(1, std::min(T, m));
            std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> band_found(static_cast<std::size_t>(bands));
            run_threads(bands, [&](int t) {
                std::vector<std::uint32_t> stamp(group.size(), std::numeric_limits<std::uint32_t>::max());
                auto& out = band_found[static_cast<std::size_t>(t)];
                const auto ka0 = static_cast<std::uint32_t>(static_cast<long long>(m) * t / bands);
                const auto ka1 = static_cast<std::uint32_t>(static_cast<long long>(m) * (t + 1) / bands);
                for (std::uint32_t ka = ka0; ka < ka1; ++ka)
                    for (const long long c : listed[ka])
                        for (const std::uint32_t kb : cells.at(c)) {
                            if (kb <= ka || stamp[kb] == ka) continue;
                            stamp[kb] = ka;
                            const P2 lo = box[ka].first.cwiseMax(box[kb].first), hi = box[ka].second.cwiseMin(box[kb].second);
                            if (lo.x() > hi.x() || lo.y() > hi.y() || apart(tri[ka], tri[kb])) continue;
                            const std::uint32_t i = group[ka], j = group[kb];
                            const double smaller = std::min(patches[i].area, patches[j].area);
                            if (overlap_area(tri[ka], tri[kb]) > 1e-6 * smaller) out.emplace_back(std::min(i, j), std::max(i, j));
                        }
            });
            std::vector<std::pair<std::uint32_t, std::uint32_t>> found;
            for (const auto& band : band_found) found.insert(found.end(), band.begin(), band.end());
            std::sort(found.begin(), found.end());
            found.erase(std::unique(found.begin(), found.end()), found.end());
            if (!found.empty() && result.pairs == 0) std::tie(result.first, result.second) = found.front();
            result.pairs += found.size();
        }
        g0 = g1;
    }
    return result;
}

}  // namespace raybundle::scenes
