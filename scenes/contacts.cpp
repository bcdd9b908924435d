#include "scenes/contacts.h"

#include "scenes/subdivide.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <unordered_set>
#include <vector>

namespace raybundle::scenes {

namespace {

struct Tri {
    std::array<Vec3, 3> p;
    Vec3 n;          // unit
    double offset;   // plane: n . x = offset
    int object;
    std::array<int, 3> vertex;
    std::array<bool, 3> region_edge;  // edge p[k] -> p[k+1] ends its planar region
};

// A contact in a patch's plane: the segment from `at` along `along` (unit) for
// `length`; `cut`: it runs through the patch's inside (cut the patch along its whole
// line), else along an edge the patch shares with a coplanar neighbour (mark it only).
struct Line {
    Vec3 at, along;
    double length;
    bool cut;
};

// Where segment a-b (in u's plane) meets triangle u: its part inside u, through u's
// inside or along an edge of u that a coplanar neighbour shares; nothing else (a
// corner, an edge of the region, outside).
std::optional<Line> contact_in(const Tri& u, const Vec3& a, const Vec3& b, double tol) {
    double lo = 0.0, hi = 1.0;
    const Vec3 d = b - a;
    std::array<Vec3, 3> inward;
    for (int k = 0; k < 3; ++k) {
        const Vec3 e = u.p[(k + 1) % 3] - u.p[k];
        inward[k] = u.n.cross(e).normalized();  // counter-clockwise about n: the inside is to the left
        // Keep the part with inward . (x - p_k) >= -tol.
        const double s0 = inward[k].dot(a - u.p[k]) + tol, sd = inward[k].dot(d);
        if (std::abs(sd) < 1e-300) {
            if (s0 < 0.0) return std::nullopt;
            continue;
        }
        const double t = -s0 / sd;
        if (sd > 0.0)
            lo = std::max(lo, t);
        else
            hi = std::min(hi, t);
    }
    const double length = (hi - lo) * d.norm();
    if (!(length > tol)) return std::nullopt;
    const Vec3 from = a + lo * d, mid = a + 0.5 * (lo + hi) * d;
    Line line{from, d.normalized(), length, true};
    for (int k = 0; k < 3; ++k)
        if (inward[k].dot(mid - u.p[k]) <= tol) {  // along edge k
            if (u.region_edge[k]) return std::nullopt;
            line.cut = false;
        }
    return line;
}

// The contact lines that triangle t makes in triangle u (see the header).
void contacts(const Tri& u, const Tri& t, double contact, double tol, std::vector<Line>& out) {
    std::array<double, 3> d;
    for (int k = 0; k < 3; ++k) d[k] = u.n.dot(t.p[k]) - u.offset;
    const double lo = std::min({d[0], d[1], d[2]}), hi = std::max({d[0], d[1], d[2]});
    if (lo > contact || hi < -contact) return;
    auto project = [&](const Vec3& x) -> Vec3 { return x - (u.n.dot(x) - u.offset) * u.n; };
    auto add = [&](const Vec3& a, const Vec3& b) {
        if (const auto line = contact_in(u, a, b, tol)) out.push_back(*line);
    };
    if (lo >= -contact && hi <= contact) {
        // Parallel: t lies at u's plane; its region's end edges cut u.
        for (int k = 0; k < 3; ++k)
            if (t.region_edge[k]) add(project(t.p[k]), project(t.p[(k + 1) % 3]));
        return;
    }
    // Transversal: the vertices near the plane and the edges' crossings of it.
    std::vector<Vec3> points;
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        if (std::abs(d[k]) <= contact) points.push_back(project(t.p[k]));
        if (std::abs(d[k]) > contact && std::abs(d[j]) > contact && d[k] * d[j] < 0.0)
            points.push_back(project(t.p[k] + d[k] / (d[k] - d[j]) * (t.p[j] - t.p[k])));
    }
    if (points.size() < 2) return;
    std::size_t a = 0, b = 1;  // the two farthest apart
    for (std::size_t i = 0; i < points.size(); ++i)
        for (std::size_t j = i + 1; j < points.size(); ++j)
            if ((points[i] - points[j]).squaredNorm() > (points[a] - points[b]).squaredNorm()) a = i, b = j;
    add(points[a], points[b]);
}

// Candidate pairs: triangles whose boxes, grown by `contact`, share a cell of a grid.
std::vector<std::pair<std::uint32_t, std::uint32_t>> candidate_pairs(const std::vector<Tri>& tris, double contact) {
    Eigen::AlignedBox3d all;
    std::vector<Eigen::AlignedBox3d> boxes(tris.size());
    for (std::size_t i = 0; i < tris.size(); ++i) {
        for (const auto& p : tris[i].p) boxes[i].extend(p);
        boxes[i].min().array() -= contact;
        boxes[i].max().array() += contact;
        all.extend(boxes[i]);
    }
    const int k = std::clamp(static_cast<int>(std::lround(2.0 * std::cbrt(static_cast<double>(tris.size())))), 1, 48);
    const Vec3 cell = (all.sizes() / k).cwiseMax(1e-300);
    auto index = [&](const Vec3& x, int axis) {
        return std::clamp(static_cast<int>((x[axis] - all.min()[axis]) / cell[axis]), 0, k - 1);
    };
    std::vector<std::vector<std::uint32_t>> cells(static_cast<std::size_t>(k) * k * k);
    for (std::size_t i = 0; i < tris.size(); ++i) {
        const auto& b = boxes[i];
        for (int x = index(b.min(), 0); x <= index(b.max(), 0); ++x)
            for (int y = index(b.min(), 1); y <= index(b.max(), 1); ++y)
                for (int z = index(b.min(), 2); z <= index(b.max(), 2); ++z)
                    cells[(static_cast<std::size_t>(x) * k + y) * k + z].push_back(static_cast<std::uint32_t>(i));
    }
    std::unordered_set<std::uint64_t> seen;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
    for (const auto& c : cells)
        for (std::size_t a = 0; a < c.size(); ++a)
            for (std::size_t b = a + 1; b < c.size(); ++b) {
                const std::uint32_t i = std::min(c[a], c[b]), j = std::max(c[a], c[b]);
                if (!boxes[i].intersects(boxes[j])) continue;
                if (seen.insert((static_cast<std::uint64_t>(i) << 32) | j).second) pairs.emplace_back(i, j);
            }
    std::sort(pairs.begin(), pairs.end());  // a fixed order, whatever the hash set's
    return pairs;
}

}  // namespace

ContactCuts cut_at_contacts(Scene& scene) {
    TriMesh& mesh = scene.mesh;
    const double radius = scene.bounds_radius();
    const double contact = 1e-3 * radius, tol = 1e-7 * radius;

    // The triangles, and which of their edges end a planar region.
    std::vector<Tri> tris;
    tris.reserve(mesh.n_faces());
    for (auto f : mesh.faces()) {
        Tri t;
        int k = 0;
        std::array<TriMesh::HalfedgeHandle, 3> hs;
        for (auto h : mesh.fh_range(f)) {
            hs[k] = h;
            t.p[k] = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
            t.vertex[k] = mesh.from_vertex_handle(h).idx();
            ++k;
        }
        t.n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalized();
        t.offset = t.n.dot(t.p[0]);
        t.object = mesh.property(scene.object_handle, f);
        for (int e = 0; e < 3; ++e) {
            const auto g = mesh.opposite_face_handle(hs[e]);
            bool coplanar = false;
            if (g.is_valid()) {
                auto it = mesh.cfv_iter(g);
                const Vec3 a = to_eigen(mesh.point(*it++)), b = to_eigen(mesh.point(*it++)), c = to_eigen(mesh.point(*it));
                const Vec3 n = (b - a).cross(c - a).normalized();
                coplanar = n.dot(t.n) > 1.0 - 1e-9 && std::abs(n.dot(a) - t.offset) <= tol;
            }
            t.region_edge[e] = !coplanar;
        }
        tris.push_back(t);
    }

    // The contact lines of every triangle.
    std::vector<std::vector<Line>> lines(tris.size());
    for (const auto& [i, j] : candidate_pairs(tris, contact)) {
        const Tri &a = tris[i], &b = tris[j];
        contacts(a, b, contact, tol, lines[i]);
        contacts(b, a, contact, tol, lines[j]);
    }

    // Cut: each line through every face that came from its triangle.
    ContactCuts cuts;
    OpenMesh::FPropHandleT<int> origin;
    mesh.add_property(origin, "contact origin");
    std::vector<std::vector<TriMesh::FaceHandle>> by_origin(tris.size());
    for (auto f : mesh.faces()) {
        mesh.property(origin, f) = f.idx();
        by_origin[static_cast<std::size_t>(f.idx())].push_back(f);
    }
    auto split = [&](TriMesh::HalfedgeHandle h, double t) {
        const auto v = split_edge(scene, h, t);
        for (auto f : mesh.vf_range(v)) by_origin[static_cast<std::size_t>(mesh.property(origin, f))].push_back(f);
        ++cuts.splits;
    };
    for (std::size_t u = 0; u < tris.size(); ++u) {
        for (const Line& line : lines[u]) {
            if (!line.cut) continue;
            const Vec3 across = tris[u].n.cross(line.along);
            bool cut = false;
            auto& faces = by_origin[u];
            std::sort(faces.begin(), faces.end());
            faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
            const std::vector<TriMesh::FaceHandle> current = faces;
            for (const auto f : current) {
                std::array<TriMesh::HalfedgeHandle, 3> hs;
                std::array<double, 3> s;
                int k = 0, on = 0;
                for (auto h : mesh.fh_range(f)) {
                    hs[k] = h;
                    s[k] = across.dot(to_eigen(mesh.point(mesh.from_vertex_handle(h))) - line.at);
                    if (std::abs(s[k]) <= tol) ++on;
                    ++k;
                }
                // The halfedges from a vertex on one side to one strictly on the other.
                std::vector<std::pair<TriMesh::HalfedgeHandle, double>> crossings;
                for (int e = 0; e < 3; ++e) {
                    const double a = s[e], b = s[(e + 1) % 3];
                    if (std::abs(a) > tol && std::abs(b) > tol && a * b < 0.0) crossings.emplace_back(hs[e], a / (a - b));
                }
                if (on >= 2 || crossings.empty() || (on == 0 && crossings.size() != 2)) continue;
                for (const auto& [h, t] : crossings) split(h, t);
                cut = true;
            }
            if (cut) ++cuts.lines;
        }
    }
    // Mark the edges that lie on a contact segment.
    for (std::size_t u = 0; u < tris.size(); ++u) {
        if (lines[u].empty()) continue;
        auto& faces = by_origin[u];
        std::sort(faces.begin(), faces.end());
        faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
        for (const Line& line : lines[u]) {
            const Vec3 across = tris[u].n.cross(line.along);
            for (const auto f : faces)
                for (auto h : mesh.fh_range(f)) {
                    const Vec3 p = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
                    const Vec3 q = to_eigen(mesh.point(mesh.to_vertex_handle(h)));
                    const double along = line.along.dot(0.5 * (p + q) - line.at);
                    if (std::abs(across.dot(p - line.at)) > tol || std::abs(across.dot(q - line.at)) > tol ||
                        along < -tol || along > line.length + tol)
                        continue;
                    const auto e = mesh.edge_handle(h);
                    if (mesh.property(scene.contact_edge_handle, e)) continue;
                    mesh.property(scene.contact_edge_handle, e) = true;
                    ++cuts.edges;
                }
        }
    }
    mesh.remove_property(origin);
    if (cuts.splits > 0 || cuts.edges > 0) scene.finalize();
    scene.contact_lines += cuts.lines;
    scene.contact_splits += cuts.splits;
    scene.contact_edges += cuts.edges;
    return cuts;
}

}  // namespace raybundle::scenes
