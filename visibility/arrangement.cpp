#include "visibility/arrangement.h"

#include "sampling/directions.h"
#include "visibility/pixel_pairs.h"

#include <CGAL/Arr_consolidated_curve_data_traits_2.h>
#include <CGAL/Arr_extended_dcel.h>
#include <CGAL/Arr_segment_traits_2.h>
#include <CGAL/Arrangement_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cstdint>
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

// Sorted patch ids; XOR with the ids on a crossed halfedge.
void toggle(std::vector<std::uint32_t>& set, const Traits::Data_container& ids) {
    for (const std::uint32_t id : ids) {
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

// Even-odd point-in-polygon test, and the distance to the nearest boundary segment.
bool contains(const Polygon& poly, const Eigen::Vector2d& q) {
    bool in = false;
    for (std::size_t k = 0, j = poly.size() - 1; k < poly.size(); j = k++) {
        const auto& a = poly[k];
        const auto& b = poly[j];
        if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
            in = !in;
    }
    return in;
}
double boundary_distance(const Polygon& poly, const Eigen::Vector2d& q) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0, j = poly.size() - 1; k < poly.size(); j = k++) {
        const Eigen::Vector2d ab = poly[k] - poly[j];
        const double t = std::clamp((q - poly[j]).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
        best = std::min(best, (poly[j] + t * ab - q).norm());
    }
    return best;
}

// A point inside face f, as far from its boundary as the candidates allow: the
// centroid of the outer boundary and the centroids of its fan triangles.
Eigen::Vector2d interior_point(Arrangement::Face_const_handle f) {
    const Polygon outer = ccb_points(f->outer_ccb());
    std::vector<Polygon> holes;
    for (auto hole = f->holes_begin(); hole != f->holes_end(); ++hole) holes.push_back(ccb_points(*hole));
    std::vector<Eigen::Vector2d> candidates;
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    double area = 0.0;
    for (std::size_t k = 1; k + 1 < outer.size(); ++k) {
        const double a = 0.5 * ((outer[k] - outer[0]).x() * (outer[k + 1] - outer[0]).y() -
                                (outer[k] - outer[0]).y() * (outer[k + 1] - outer[0]).x());
        const Eigen::Vector2d c = (outer[0] + outer[k] + outer[k + 1]) / 3.0;
        candidates.push_back(c);
        centroid += a * c;
        area += a;
    }
    if (area != 0.0) candidates.insert(candidates.begin(), centroid / area);
    Eigen::Vector2d best = outer[0];
    double best_distance = -1.0;
    for (const auto& c : candidates) {
        if (!contains(outer, c)) continue;
        bool in_hole = false;
        for (const auto& h : holes) in_hole = in_hole || contains(h, c);
        if (in_hole) continue;
        double d = boundary_distance(outer, c);
        for (const auto& h : holes) d = std::min(d, boundary_distance(h, c));
        if (d > best_distance) {
            best = c;
            best_distance = d;
        }
    }
    return best;
}

}  // namespace

struct ArrangementBackend::Impl {
    std::vector<Vec3> positions;
    std::vector<std::array<int, 3>> triangles;
    std::vector<Vec3> normals;
    std::vector<double> plane;  // n . p0
    Vec3 center;
    double extent;              // the bounding sphere's radius: the scale of depths
};

ArrangementBackend::ArrangementBackend(const scenes::Scene& scene) : impl_(std::make_unique<Impl>()) {
    impl_->positions = scene.vertex_positions();
    impl_->center = scene.bounds_center();
    impl_->extent = scene.bounds_radius();
    for (const auto& p : scene.patch_list()) {
        impl_->triangles.push_back({p.v[0], p.v[1], p.v[2]});
        impl_->normals.push_back(p.normal);
        impl_->plane.push_back(p.normal.dot(impl_->positions[p.v[0]]));
    }
}

ArrangementBackend::~ArrangementBackend() = default;

void ArrangementBackend::transfer(const Vec3& w, const Eigen::Vector2d& /*jitter*/, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    const Impl& s = *impl_;
    Vec3 u, v;
    sampling::orthonormal_basis(w, u, v);

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
        if (s.normals[i].dot(w) == 0.0) continue;
        const auto& t = s.triangles[i];
        for (int k = 0; k < 3; ++k) {
            const Point& a = projected[t[k]];
            const Point& b = projected[t[(k + 1) % 3]];
            if (a != b) curves.emplace_back(Kernel::Segment_2(a, b), i);
        }
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
        if (set.size() < 2) continue;
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
        // By depth; coincident patches receivers first (a two-sided panel does not leak).
        std::vector<std::size_t> idx(set.size());
        for (std::size_t k = 0; k < idx.size(); ++k) idx[k] = k;
        std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
            if (depth[a] != depth[b]) return depth[a] < depth[b];
            return s.normals[set[a]].dot(w) < s.normals[set[b]].dot(w);
        });
        for (std::size_t k = 0; k + 1 < idx.size(); ++k) {
            const std::uint32_t a = set[idx[k]], b = set[idx[k + 1]];
            if (s.normals[a].dot(w) > 0.0 && s.normals[b].dot(w) < 0.0) {
                pairs.push_back(pixel_pair(b, a));
                areas.push_back(area);
            }
        }
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
