#include "visibility/arrangement.h"

#include "scenes/frame.h"
#include "visibility/pixel_pairs.h"

#include <CGAL/Arr_consolidated_curve_data_traits_2.h>
#include <CGAL/Arr_extended_dcel.h>
#include <CGAL/Arr_segment_traits_2.h>
#include <CGAL/Arrangement_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_map>
#include <limits>
#include <vector>

namespace raybundle::visibility {

namespace {

using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using SegmentTraits = CGAL::Arr_segment_traits_2<Kernel>;
using Traits = CGAL::Arr_consolidated_curve_data_traits_2<SegmentTraits, std::uint32_t>;
using Dcel = CGAL::Arr_face_extended_dcel<Traits, int>;  // face data: index into the coverage table
using Arrangement = CGAL::Arrangement_2<Traits, Dcel>;
using Point = Kernel::Point_2;

// Curves that bound no patch: where two patches cross each other in 3-D.
constexpr std::uint32_t kCrossing = 0xFFFFFFFFu;

// Sorted patch ids; XOR with the ids on a crossed halfedge.
void toggle(std::vector<std::uint32_t>& set, const Traits::Data_container& ids) {
    for (const std::uint32_t id : ids) {
        if (id == kCrossing) continue;
        const auto it = std::lower_bound(set.begin(), set.end(), id);
        if (it != set.end() && *it == id)
            set.erase(it);
        else
            set.insert(it, id);
    }
}

using Polygon = std::vector<Eigen::Vector2d>;

Polygon ccb_points(Arrangement::Ccb_halfedge_const_circulator first) {
    Polygon p;
    auto h = first;
    do {
        p.emplace_back(CGAL::to_double(h->source()->point().x()), CGAL::to_double(h->source()->point().y()));
    } while (++h != first);
    return p;
}

// A point inside face f, well away from its boundary: on horizontal lines halfway
// between the y levels of its vertices, the boundary crossings (outer boundary and
// holes, even-odd) split the line into inside and outside intervals; the middle of
// the widest inside interval wins. Works for non-convex faces and faces with holes.
Eigen::Vector2d interior_point(Arrangement::Face_const_handle f) {
    std::vector<Polygon> rings{ccb_points(f->outer_ccb())};
    for (auto hole = f->holes_begin(); hole != f->holes_end(); ++hole) rings.push_back(ccb_points(*hole));
    std::vector<double> ys;
    for (const auto& ring : rings)
        for (const auto& p : ring) ys.push_back(p.y());
    std::sort(ys.begin(), ys.end());
    ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
    Eigen::Vector2d best = rings[0][0];
    double best_width = -1.0;
    std::vector<double> xs;
    for (std::size_t k = 0; k + 1 < ys.size(); ++k) {
        const double y = 0.5 * (ys[k] + ys[k + 1]);
        xs.clear();
        for (const auto& ring : rings)
            for (std::size_t a = 0, b = ring.size() - 1; a < ring.size(); b = a++) {
                const Eigen::Vector2d& p = ring[a];
                const Eigen::Vector2d& q = ring[b];
                if ((p.y() > y) != (q.y() > y)) xs.push_back(p.x() + (y - p.y()) * (q.x() - p.x()) / (q.y() - p.y()));
            }
        std::sort(xs.begin(), xs.end());
        for (std::size_t i = 0; i + 1 < xs.size(); i += 2) {
            // The interval's width, but also its distance to the neighbouring vertex levels.
            const double width = std::min(xs[i + 1] - xs[i], 2.0 * std::min(y - ys[k], ys[k + 1] - y));
            if (width > best_width) {
                best_width = width;
                best = Eigen::Vector2d(0.5 * (xs[i] + xs[i + 1]), y);
            }
        }
    }
    return best;
}

// The segments along which pairs of patches properly cross each other (each patch
// has corners strictly on both sides of the other's plane): 3-D lines across which
// the depth order of the two changes, to be added to every arrangement. Patches that
// only touch (along an edge or at a corner) do not cross. Candidate pairs come from a
// uniform grid over the patches' bounding boxes.
std::vector<std::pair<Vec3, Vec3>> crossing_segments(const std::vector<Vec3>& pos,
                                                     const std::vector<std::array<int, 3>>& tris, double extent) {
    const std::size_t n = tris.size();
    std::vector<std::pair<Vec3, Vec3>> segments;
    if (n < 2) return segments;
    Vec3 lo = pos[tris[0][0]], hi = lo;
    double mean_size = 0.0;
    std::vector<Vec3> bmin(n), bmax(n);
    for (std::size_t i = 0; i < n; ++i) {
        bmin[i] = bmax[i] = pos[tris[i][0]];
        for (int k = 1; k < 3; ++k) {
            bmin[i] = bmin[i].cwiseMin(pos[tris[i][k]]);
            bmax[i] = bmax[i].cwiseMax(pos[tris[i][k]]);
        }
        lo = lo.cwiseMin(bmin[i]);
        hi = hi.cwiseMax(bmax[i]);
        mean_size += (bmax[i] - bmin[i]).maxCoeff();
    }
    const double cell = std::max(mean_size / static_cast<double>(n), 1e-9 * extent) * 2.0;
    std::array<int, 3> cells;
    for (int k = 0; k < 3; ++k) cells[k] = static_cast<int>(std::floor((hi[k] - lo[k]) / cell)) + 1;
    auto cell_of = [&](const Vec3& p) {
        std::array<int, 3> c;
        for (int k = 0; k < 3; ++k) c[k] = std::clamp(static_cast<int>(std::floor((p[k] - lo[k]) / cell)), 0, cells[k] - 1);
        return c;
    };
    std::unordered_map<long long, std::vector<std::uint32_t>> grid;
    auto key = [&](int x, int y, int z) { return (static_cast<long long>(z) * cells[1] + y) * cells[0] + x; };
    for (std::uint32_t i = 0; i < n; ++i) {
        const auto a = cell_of(bmin[i]), b = cell_of(bmax[i]);
        for (int z = a[2]; z <= b[2]; ++z)
            for (int y = a[1]; y <= b[1]; ++y)
                for (int x = a[0]; x <= b[0]; ++x) grid[key(x, y, z)].push_back(i);
    }
    const double eps = 1e-9 * extent;
    auto side = [&](const Vec3& normal, double d, const Vec3& p) {
        const double s = normal.dot(p) - d;
        return s > eps ? 1 : (s < -eps ? -1 : 0);
    };
    std::vector<std::pair<std::uint32_t, std::uint32_t>> tested;
    for (const auto& [k, members] : grid)
        for (std::size_t p = 0; p < members.size(); ++p)
            for (std::size_t q = p + 1; q < members.size(); ++q) {
                const std::uint32_t i = std::min(members[p], members[q]), j = std::max(members[p], members[q]);
                if (((bmin[i] - bmax[j]).array() > eps).any() || ((bmin[j] - bmax[i]).array() > eps).any()) continue;
                tested.emplace_back(i, j);
            }
    std::sort(tested.begin(), tested.end());
    tested.erase(std::unique(tested.begin(), tested.end()), tested.end());
    for (const auto& [i, j] : tested) {
        const Vec3 *A[3] = {&pos[tris[i][0]], &pos[tris[i][1]], &pos[tris[i][2]]};
        const Vec3 *B[3] = {&pos[tris[j][0]], &pos[tris[j][1]], &pos[tris[j][2]]};
        const Vec3 na = (*A[1] - *A[0]).cross(*A[2] - *A[0]).normalized(), nb = (*B[1] - *B[0]).cross(*B[2] - *B[0]).normalized();
        const double da = na.dot(*A[0]), db = nb.dot(*B[0]);
        int sa[3], sb[3];
        for (int k = 0; k < 3; ++k) {
            sa[k] = side(nb, db, *A[k]);
            sb[k] = side(na, da, *B[k]);
        }
        // Proper crossing: strictly on both sides, both ways.
        auto straddles = [](const int s[3]) {
            return (s[0] > 0 || s[1] > 0 || s[2] > 0) && (s[0] < 0 || s[1] < 0 || s[2] < 0);
        };
        if (!straddles(sa) || !straddles(sb)) continue;
        // Where each triangle meets the other's plane: a segment on the common line.
        auto cut = [&](const Vec3* const T[3], const Vec3& normal, double d, Vec3& p0, Vec3& p1) {
            int found = 0;
            for (int k = 0; k < 3 && found < 2; ++k) {
                const Vec3& a = *T[k];
                const Vec3& b = *T[(k + 1) % 3];
                const double fa = normal.dot(a) - d, fb = normal.dot(b) - d;
                if ((fa > 0) != (fb > 0) && fa != fb) (found++ == 0 ? p0 : p1) = a + (b - a) * (fa / (fa - fb));
            }
            return found == 2;
        };
        Vec3 a0, a1, b0, b1;
        if (!cut(A, nb, db, a0, a1) || !cut(B, na, da, b0, b1)) continue;
        const Vec3 dir = na.cross(nb);
        double ta0 = dir.dot(a0), ta1 = dir.dot(a1), tb0 = dir.dot(b0), tb1 = dir.dot(b1);
        if (ta0 > ta1) std::swap(a0, a1), std::swap(ta0, ta1);
        if (tb0 > tb1) std::swap(b0, b1), std::swap(tb0, tb1);
        const Vec3& s0 = ta0 > tb0 ? a0 : b0;
        const Vec3& s1 = ta1 < tb1 ? a1 : b1;
        if (std::max(ta0, tb0) < std::min(ta1, tb1)) segments.emplace_back(s0, s1);
    }
    return segments;
}

}  // namespace

struct ArrangementBackend::Impl {
    std::vector<std::pair<Vec3, Vec3>> crossings;  // 3-D segments where patches cross
    std::vector<Vec3> positions;
    std::vector<std::array<int, 3>> triangles;
    std::vector<Vec3> normals;
    std::vector<double> plane;  // n . p0
    Vec3 center;
    double extent;              // the bounding sphere's radius: the scale of depths
    bool sky = false;           // also the sky entries
};

ArrangementBackend::ArrangementBackend(const scenes::Scene& scene, bool sky) : impl_(std::make_unique<Impl>()) {
    impl_->sky = sky;
    impl_->positions = scene.vertex_positions();
    impl_->center = scene.bounds_center();
    impl_->extent = scene.bounds_radius();
    for (const auto& p : scene.patch_list()) {
        impl_->triangles.push_back({p.v[0], p.v[1], p.v[2]});
        impl_->normals.push_back(p.normal);
        impl_->plane.push_back(p.normal.dot(impl_->positions[p.v[0]]));
    }
    impl_->crossings = crossing_segments(impl_->positions, impl_->triangles, impl_->extent);

}

ArrangementBackend::~ArrangementBackend() = default;

void ArrangementBackend::transfer(const Vec3& w, const Eigen::Vector2d& /*jitter*/, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    const Impl& s = *impl_;
    Vec3 u, v;
    scenes::orthonormal_basis(w, u, v);

    // Project the vertices (doubles are exact inputs for the exact kernel).
    std::vector<Point> projected;
    projected.reserve(s.positions.size());
    for (const auto& p : s.positions) {
        const Vec3 d = p - s.center;
        projected.emplace_back(u.dot(d), v.dot(d));
    }
    // Each patch's edges, tagged with the patch; edge-on patches cover nothing.
    std::vector<Traits::Curve_2> curves;
    curves.reserve(3 * s.triangles.size());
    for (std::uint32_t i = 0; i < s.triangles.size(); ++i) {
        const auto& t = s.triangles[i];
        // Seen edge-on (exactly, in the projection): covers nothing. Its edges would
        // overlap with the same patch id, which the coverage walk cannot toggle right.
        if (CGAL::collinear(projected[t[0]], projected[t[1]], projected[t[2]])) continue;
        for (int k = 0; k < 3; ++k) {
            const Point& a = projected[t[k]];
            const Point& b = projected[t[(k + 1) % 3]];
            if (a != b) curves.emplace_back(Kernel::Segment_2(a, b), i);
        }
    }
    // A crossing segment ends on patch edges, but its rounded end points need not lie
    // exactly on their projections: extended a little at both ends, it surely cuts
    // through them and splits the faces it must (an end point short of the edge would
    // leave a dangling edge inside one face, with one depth order for both sides).
    const double reach = 1e-7 * s.extent;
    for (const auto& [a3, b3] : s.crossings) {
        const Vec3 along = (b3 - a3).normalized() * reach;
        const Vec3 da = a3 - along - s.center, db = b3 + along - s.center;
        const Point a(u.dot(da), v.dot(da)), b(u.dot(db), v.dot(db));
        if (a != b) curves.emplace_back(Kernel::Segment_2(a, b), kCrossing);
    }
    Arrangement arr;
    CGAL::insert(arr, curves.begin(), curves.end());

    // Coverage of every face: walk from the unbounded face (covered by nothing); crossing
    // a halfedge toggles the patches whose edges it lies on.
    std::vector<std::vector<std::uint32_t>> coverage;
    for (auto f = arr.faces_begin(); f != arr.faces_end(); ++f) f->set_data(-1);
    std::vector<Arrangement::Face_handle> queue{arr.unbounded_face()};
    arr.unbounded_face()->set_data(0);
    coverage.emplace_back();
    auto visit_ccb = [&](Arrangement::Ccb_halfedge_circulator first, int from) {
        auto h = first;
        do {
            const auto next = h->twin()->face();
            if (next->data() < 0) {
                std::vector<std::uint32_t> set = coverage[from];
                toggle(set, h->curve().data());
                next->set_data(static_cast<int>(coverage.size()));
                coverage.push_back(std::move(set));
                queue.push_back(next);
            }
        } while (++h != first);
    };
    for (std::size_t q = 0; q < queue.size(); ++q) {
        const auto f = queue[q];
        const int from = f->data();
        if (!f->is_unbounded()) visit_ccb(f->outer_ccb(), from);
        for (auto hole = f->holes_begin(); hole != f->holes_end(); ++hole) visit_ccb(*hole, from);
    }

    // Per face: exact area, depth order, pairs.
    std::vector<std::uint64_t> pairs;
    std::vector<double> areas;
    for (auto f = arr.faces_begin(); f != arr.faces_end(); ++f) {
        if (f->is_unbounded()) continue;
        const auto& set = coverage[f->data()];
        if (set.size() < (s.sky ? 1u : 2u)) continue;
        auto ccb_area = [](Arrangement::Ccb_halfedge_const_circulator first) {
            Kernel::FT sum = 0;
            auto h = first;
            do {
                const Point& a = h->source()->point();
                const Point& b = h->target()->point();
                sum += a.x() * b.y() - a.y() * b.x();
            } while (++h != first);
            return sum;
        };
        Kernel::FT twice = ccb_area(f->outer_ccb());
        for (auto hole = f->holes_begin(); hole != f->holes_end(); ++hole) twice += ccb_area(*hole);  // clockwise: negative
        const double area = CGAL::to_double(twice) / 2.0;
        if (!(area > 0.0)) continue;

        // Depth of each covering patch at a point well inside the face. Projections of
        // edges that coincide in 3-D (walls meeting at a corner) are collinear only up
        // to rounding, so a point on the face's boundary can sit on the wrong side of
        // such an edge: take the candidate (the face's centroid, or the centroid of one
        // of its fan triangles) that lies inside and farthest from the boundary.
        const Eigen::Vector2d inside = interior_point(f);
        const Vec3 m = s.center + inside.x() * u + inside.y() * v;
        std::vector<double> depth(set.size());
        for (std::size_t k = 0; k < set.size(); ++k) {
            const std::uint32_t i = set[k];
            depth[k] = (s.plane[i] - s.normals[i].dot(m)) / s.normals[i].dot(w);
        }
        // By depth; coincident patches (up to rounding) ordered as in every backend: a
        // two-sided panel does not leak.
        std::vector<std::size_t> idx(set.size());
        for (std::size_t k = 0; k < idx.size(); ++k) idx[k] = k;
        std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return depth[a] < depth[b]; });
        order_ties(idx.begin(), idx.end(), 1e-9 * s.extent, [&](std::size_t k) { return depth[k]; },
                   [&](std::size_t k) { return s.normals[set[k]].dot(w) > 0.0; }, [&](std::size_t k) { return set[k]; });
        pairs_along(idx.begin(), idx.end(), [&](std::size_t k) { return set[k]; },
                    [&](std::size_t k) { return s.normals[set[k]].dot(w) > 0.0; }, s.sky,
                    static_cast<std::uint32_t>(s.normals.size()), [&](std::uint32_t r, std::uint32_t src) {
                        pairs.push_back(pixel_pair(r, src));
                        areas.push_back(area);
                    });
    }
    // Group by (receiver, source), summing areas.
    std::vector<std::size_t> perm(pairs.size());
    for (std::size_t k = 0; k < perm.size(); ++k) perm[k] = k;
    std::sort(perm.begin(), perm.end(), [&](std::size_t a, std::size_t b) { return pairs[a] < pairs[b]; });
    for (std::size_t k = 0; k < perm.size();) {
        const std::uint64_t key = pairs[perm[k]];
        double sum = 0.0;
        for (; k < perm.size() && pairs[perm[k]] == key; ++k) sum += areas[perm[k]];
        out.entries.push_back({static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key), sum});
    }
}

}  // namespace raybundle::visibility
