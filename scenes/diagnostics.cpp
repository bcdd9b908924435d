#include "scenes/diagnostics.h"

#include "scenes/sorted_cells.h"
#include "scenes/threads.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <tuple>
#include <utility>
#include <vector>

namespace raybundle::scenes {

namespace {

using P2 = Eigen::Vector2d;

double cross(const P2& a, const P2& b) { return a.x() * b.y() - a.y() * b.x(); }

// The area of the intersection of two triangles (Sutherland-Hodgman: clip one by the
// other's three edges, counter-clockwise).
double overlap_area(std::array<P2, 3> a, std::array<P2, 3> b) {
    // Relative to a's first corner: far from the plane's origin the corners' large
    // coordinates would cancel in the cross products (a square 1e-3 wide at 1e9 lost
    // all of its area to rounding).
    const P2 o = a[0];
    for (auto* t : {&a, &b})
        for (P2& c : *t) c -= o;
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

// Whether a triangle meets the closed rectangle lo..hi (separating axes: the
// rectangle's two, then the triangle's three edge normals).
bool meets_rectangle(const std::array<P2, 3>& t, const P2& lo, const P2& hi) {
    P2 t_lo = t[0], t_hi = t[0];
    for (const P2& c : t) t_lo = t_lo.cwiseMin(c), t_hi = t_hi.cwiseMax(c);
    if (t_hi.x() < lo.x() || t_lo.x() > hi.x() || t_hi.y() < lo.y() || t_lo.y() > hi.y()) return false;
    const std::array<P2, 4> corners = {lo, P2(hi.x(), lo.y()), hi, P2(lo.x(), hi.y())};
    for (int e = 0; e < 3; ++e) {
        const P2 d = t[(e + 1) % 3] - t[e], axis(-d.y(), d.x());
        const auto [a0, a1] = extent(t, axis);
        double b0 = axis.dot(corners[0]), b1 = b0;
        for (const P2& c : corners) b0 = std::min(b0, axis.dot(c)), b1 = std::max(b1, axis.dot(c));
        if (a1 < b0 || b1 < a0) return false;
    }
    return true;
}

// The cells (x, y) of the block x0..x1, y0..y1 (inclusive) that a triangle meets: the
// block tested first, then its halves, so that a sliver across many cells costs tests
// along it, not over its bounding box (a diagonal sliver of 2,000 cells: 2,000 x 2,000
// cells of its box tested one by one).
template <class Out>
void list_squares(const std::array<P2, 3>& t, long long x0, long long y0, long long x1, long long y1, double cell,
                  const Out& out) {
    if (!meets_rectangle(t, P2(static_cast<double>(x0) * cell, static_cast<double>(y0) * cell),
                         P2(static_cast<double>(x1 + 1) * cell, static_cast<double>(y1 + 1) * cell)))
        return;
    if (x0 == x1 && y0 == y1) {
        out(x0, y0);
        return;
    }
    if (x1 - x0 >= y1 - y0) {
        const long long mid = x0 + (x1 - x0) / 2;
        list_squares(t, x0, y0, mid, y1, cell, out);
        list_squares(t, mid + 1, y0, x1, y1, cell, out);
    } else {
        const long long mid = y0 + (y1 - y0) / 2;
        list_squares(t, x0, y0, x1, mid, cell, out);
        list_squares(t, x0, mid + 1, x1, y1, cell, out);
    }
}

}  // namespace

CoplanarOverlaps coplanar_overlaps(const Scene& scene, int threads) {
    CoplanarOverlaps result;
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const std::size_t n = patches.size();
    if (n < 2) return result;
    const double tol = 1e-9 * scene.bounds_radius();

    // Group by plane: the normal rounded to 1e-6, then the offset n . p within tol
    // (the patch index last: one order for any sort).
    struct Key {
        long long nx, ny, nz;
        double offset;
        std::uint32_t patch;
    };
    std::vector<Key> keys(n);
    parallel_chunks(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
            const Vec3& nrm = patches[i].normal;
            keys[i] = {std::llround(nrm.x() * 1e6), std::llround(nrm.y() * 1e6), std::llround(nrm.z() * 1e6),
                       nrm.dot(pos[patches[i].v[0]]), static_cast<std::uint32_t>(i)};
        }
    });
    parallel_sort(keys, threads, [](const Key& a, const Key& b) {
        if (a.nx != b.nx) return a.nx < b.nx;
        if (a.ny != b.ny) return a.ny < b.ny;
        if (a.nz != b.nz) return a.nz < b.nz;
        if (a.offset != b.offset) return a.offset < b.offset;
        return a.patch < b.patch;
    });

    // The planes of two patches or more, each with a 2-D frame relative to its first
    // corner (offsets far from the origin keep their precision) and a uniform grid of
    // cells about two patches wide (or wider: see below).
    struct Plane {
        std::size_t begin, end;  // its patches: keys[begin .. end)
        Vec3 u, v, origin;
        double cell;
    };
    std::vector<Plane> planes;
    for (std::size_t g0 = 0; g0 < n;) {
        std::size_t g1 = g0 + 1;
        while (g1 < n && keys[g1].nx == keys[g0].nx && keys[g1].ny == keys[g0].ny && keys[g1].nz == keys[g0].nz &&
               keys[g1].offset - keys[g1 - 1].offset <= tol)
            ++g1;
        if (g1 - g0 >= 2) {
            const Vec3 normal = patches[keys[g0].patch].normal;
            const Vec3 u = normal.unitOrthogonal();
            double area = 0.0;
            for (std::size_t k = g0; k < g1; ++k) area += patches[keys[k].patch].area;
            planes.push_back({g0, g1, u, normal.cross(u), pos[patches[keys[g0].patch].v[0]],
                              2.0 * std::sqrt(area / static_cast<double>(g1 - g0))});
        }
        g0 = g1;
    }
    if (planes.empty()) return result;

    // All planes' patches as one list of members (plane by plane), on the threads: each
    // member's triangle in its plane's frame and its box.
    std::vector<std::uint32_t> plane_of, patch_of;
    for (std::size_t g = 0; g < planes.size(); ++g)
        for (std::size_t k = planes[g].begin; k < planes[g].end; ++k) {
            plane_of.push_back(static_cast<std::uint32_t>(g));
            patch_of.push_back(keys[k].patch);
        }
    const std::size_t m = patch_of.size();
    std::vector<std::array<P2, 3>> tri(m);
    std::vector<std::pair<P2, P2>> box(m);
    parallel_chunks(static_cast<int>(m), threads, [&](int k0, int k1) {
        for (auto k = static_cast<std::size_t>(k0); k < static_cast<std::size_t>(k1); ++k) {
            const Plane& g = planes[plane_of[k]];
            const Patch& p = patches[patch_of[k]];
            for (int c = 0; c < 3; ++c) tri[k][c] = P2(g.u.dot(pos[p.v[c]] - g.origin), g.v.dot(pos[p.v[c]] - g.origin));
            P2 lo = tri[k][0], hi = tri[k][0];
            for (const P2& c : tri[k]) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
            box[k] = {lo, hi};
        }
    });
    // Cells two patches wide by area are a sliver's width: each sliver was listed along
    // all of its length (2,000 slivers of 1 x 1e-7 in a plane: 4.5 million listings,
    // 240 MB). So a plane's cells are at least its median member's box (the longer side).
    std::vector<double> sides;
    for (std::size_t g = 0, k0 = 0; g < planes.size(); ++g) {
        const std::size_t count = planes[g].end - planes[g].begin;
        sides.resize(count);
        for (std::size_t i = 0; i < count; ++i) sides[i] = (box[k0 + i].second - box[k0 + i].first).maxCoeff();
        std::nth_element(sides.begin(), sides.begin() + static_cast<long>(count / 2), sides.end());
        planes[g].cell = std::max(planes[g].cell, sides[count / 2]);
        k0 += count;
    }
    // Each plane's cells numbered row by row after the planes before it, where all the
    // numbers stay below 2^53 (exact in the double that counts them; a short key sorts
    // in few passes); else the plane's index
    // and the cell's coordinates hashed into the key (two members share a key only in
    // one plane, or by a wrap of its bits, which the plane test below catches).
    struct Span {
        long long x0 = std::numeric_limits<long long>::max(), y0 = x0, x1 = std::numeric_limits<long long>::min(), y1 = x1;
        std::uint64_t base = 0;
    };
    std::vector<Span> span(planes.size());
    auto cell_of = [&](std::size_t k, const P2& at) {
        const double c = planes[plane_of[k]].cell;
        return std::make_pair(std::llround(std::floor(at.x() / c)), std::llround(std::floor(at.y() / c)));
    };
    for (std::size_t k = 0; k < m; ++k) {
        Span& g = span[plane_of[k]];
        const auto [x0, y0] = cell_of(k, box[k].first);
        const auto [x1, y1] = cell_of(k, box[k].second);
        g.x0 = std::min(g.x0, x0), g.y0 = std::min(g.y0, y0), g.x1 = std::max(g.x1, x1), g.y1 = std::max(g.y1, y1);
    }
    double numbered = 0.0;
    for (Span& g : span) {
        g.base = static_cast<std::uint64_t>(numbered);
        numbered += (static_cast<double>(g.x1 - g.x0) + 1.0) * (static_cast<double>(g.y1 - g.y0) + 1.0);
    }
    const bool dense = numbered < 0x1p53;
    // The cells each member meets, not all its box covers (a sliver across the plane
    // meets a line of cells, its box a square of them).
    std::vector<std::vector<std::uint64_t>> listed(m);
    parallel_chunks(static_cast<int>(m), threads, [&](int k0, int k1) {
        for (auto k = static_cast<std::size_t>(k0); k < static_cast<std::size_t>(k1); ++k) {
            const double cell = planes[plane_of[k]].cell;
            const Span& g = span[plane_of[k]];
            const auto [x0, y0] = cell_of(k, box[k].first);
            const auto [x1, y1] = cell_of(k, box[k].second);
            list_squares(tri[k], x0, y0, x1, y1, cell, [&](long long x, long long y) {
                listed[k].push_back(
                    dense ? g.base + static_cast<std::uint64_t>(x - g.x0) * static_cast<std::uint64_t>(g.y1 - g.y0 + 1) +
                                static_cast<std::uint64_t>(y - g.y0)
                          : static_cast<std::uint64_t>(plane_of[k]) << 44 ^ (static_cast<std::uint64_t>(x) & 0x3fffff) << 22 ^
                                (static_cast<std::uint64_t>(y) & 0x3fffff));
            });
        }
    });
    const SortedCells cells(listed, threads);
    result.listings = cells.first.back();

    // Each member against the later members of its cells (each pair tested once: the
    // stamp says which member last took it), on the threads; the pairs sorted below
    // whatever the split.
    struct Found {
        std::uint32_t plane, i, j;
        bool operator<(const Found& o) const { return std::tie(plane, i, j) < std::tie(o.plane, o.i, o.j); }
        bool operator==(const Found& o) const { return plane == o.plane && i == o.i && j == o.j; }
    };
    const int T = std::max(1, std::min(threads, static_cast<int>(m)));
    std::vector<std::vector<Found>> found_by(static_cast<std::size_t>(T));
    std::vector<std::vector<std::uint32_t>> stamps(static_cast<std::size_t>(T));
    parallel_chunks(static_cast<int>(m), threads, [&](int k0, int k1, int t) {
        auto& stamp = stamps[static_cast<std::size_t>(t)];
        if (stamp.empty()) stamp.assign(m, std::numeric_limits<std::uint32_t>::max());
        auto& out = found_by[static_cast<std::size_t>(t)];
        for (auto ka = static_cast<std::uint32_t>(k0); ka < static_cast<std::uint32_t>(k1); ++ka)
            for (std::size_t s = cells.first[ka]; s < cells.first[ka + 1]; ++s) {
                const std::uint32_t r = cells.run_of[s];
                for (std::size_t c = cells.run_start[r]; c < cells.run_start[r + 1]; ++c) {
                    const std::uint32_t kb = cells.members[c];
                    if (kb <= ka || stamp[kb] == ka || plane_of[kb] != plane_of[ka]) continue;
                    stamp[kb] = ka;
                    const P2 lo = box[ka].first.cwiseMax(box[kb].first), hi = box[ka].second.cwiseMin(box[kb].second);
                    if (lo.x() > hi.x() || lo.y() > hi.y() || apart(tri[ka], tri[kb])) continue;
                    const std::uint32_t i = patch_of[ka], j = patch_of[kb];
                    const double smaller = std::min(patches[i].area, patches[j].area);
                    if (overlap_area(tri[ka], tri[kb]) > 1e-6 * smaller)
                        out.push_back({plane_of[ka], std::min(i, j), std::max(i, j)});
                }
            }
    });
    std::vector<Found> found;
    for (const auto& part : found_by) found.insert(found.end(), part.begin(), part.end());
    std::sort(found.begin(), found.end());
    found.erase(std::unique(found.begin(), found.end()), found.end());
    result.pairs = found.size();
    // The example: the first pair of the first plane that has one.
    if (!found.empty()) std::tie(result.first, result.second) = std::make_pair(found.front().i, found.front().j);
    return result;
}

}  // namespace raybundle::scenes
