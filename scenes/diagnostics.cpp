#include "scenes/diagnostics.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>
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

}  // namespace

CoplanarOverlaps coplanar_overlaps(const Scene& scene) {
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
            for (std::size_t k = g0; k < g1; ++k) {
                const Patch& p = patches[keys[k].patch];
                group.push_back(keys[k].patch);
                std::array<P2, 3> t;
                for (int c = 0; c < 3; ++c) t[c] = P2(u.dot(pos[p.v[c]]), v.dot(pos[p.v[c]]));
                tri.push_back(t);
                area += p.area;
            }
            const double cell = 2.0 * std::sqrt(area / static_cast<double>(group.size()));
            for (std::uint32_t k = 0; k < group.size(); ++k) {
                P2 lo = tri[k][0], hi = tri[k][0];
                for (const P2& c : tri[k]) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
                const long long x0 = std::llround(std::floor(lo.x() / cell)), x1 = std::llround(std::floor(hi.x() / cell));
                const long long y0 = std::llround(std::floor(lo.y() / cell)), y1 = std::llround(std::floor(hi.y() / cell));
                for (long long x = x0; x <= x1; ++x)
                    for (long long y = y0; y <= y1; ++y) cells[x * 1000003LL + y].push_back(k);
            }
            std::vector<std::pair<std::uint32_t, std::uint32_t>> found;
            for (const auto& [cell_key, members] : cells)
                for (std::size_t a = 0; a < members.size(); ++a)
                    for (std::size_t b = a + 1; b < members.size(); ++b) {
                        const std::uint32_t i = group[members[a]], j = group[members[b]];
                        const double smaller = std::min(patches[i].area, patches[j].area);
                        if (overlap_area(tri[members[a]], tri[members[b]]) > 1e-6 * smaller)
                            found.emplace_back(std::min(i, j), std::max(i, j));
                    }
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
