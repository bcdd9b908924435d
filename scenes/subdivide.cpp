#include "scenes/subdivide.h"

#include "scenes/errors.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <iomanip>
#include <sstream>

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

namespace raybundle::scenes {
namespace {

// The corner normals of the face on one side of an edge a-b before its split: at a,
// at b, at the opposite vertex w, and the new vertex's (the normalised blend of a's and
// b's at the split; a zero blend, possible only with file normals, leaves it to
// finalize()).
struct Side {
    TriMesh::VertexHandle a, b, w;
    std::array<double, 3> at_a, at_b, at_w, mid;
    bool valid = false;
};

// h runs from a to b inside the face; the new vertex lies at a + t (b - a).
Side side_of(const TriMesh& mesh, OpenMesh::HPropHandleT<std::array<double, 3>> normal, TriMesh::HalfedgeHandle h,
             double t) {
    Side s;
    if (!mesh.face_handle(h).is_valid()) return s;
    const auto next = mesh.next_halfedge_handle(h), prev = mesh.prev_halfedge_handle(h);
    s.a = mesh.from_vertex_handle(h);
    s.b = mesh.to_vertex_handle(h);
    s.w = mesh.to_vertex_handle(next);
    s.at_a = mesh.property(normal, prev);
    s.at_b = mesh.property(normal, h);
    s.at_w = mesh.property(normal, next);
    const Vec3 sum = (1.0 - t) * to_eigen(s.at_a) + t * to_eigen(s.at_b);
    s.mid = to_array(sum.norm() > 0.0 ? Vec3(sum.normalized()) : Vec3::Zero());
    s.valid = true;
    return s;
}

}  // namespace

TriMesh::VertexHandle split_edge(Scene& scene, TriMesh::HalfedgeHandle h, double t) {
    TriMesh& mesh = scene.mesh;
    const auto normal = scene.corner_normal_handle;
    const auto at = (1.0 - t) * mesh.point(mesh.from_vertex_handle(h)) + t * mesh.point(mesh.to_vertex_handle(h));
    const Side sides[2] = {side_of(mesh, normal, h, t), side_of(mesh, normal, mesh.opposite_halfedge_handle(h), 1.0 - t)};
    const auto ends = std::make_pair(mesh.from_vertex_handle(h), mesh.to_vertex_handle(h));
    const auto m = mesh.split_copy(mesh.edge_handle(h), at);
    // Every face around the new vertex m is part of an old face: of the one on side s
    // when it holds m -> s.b or s.a -> m (s.a -> s.b was its halfedge). The edges from
    // m to the opposite vertices are new: no contact edges (split_copy copied the split
    // edge's mark to them).
    for (auto out : mesh.voh_range(m)) {
        const auto to = mesh.to_vertex_handle(out);
        if (to != ends.first && to != ends.second) mesh.property(scene.contact_edge_handle, mesh.edge_handle(out)) = false;
        if (!mesh.face_handle(out).is_valid()) continue;
        const auto next = mesh.next_halfedge_handle(out), in = mesh.next_halfedge_handle(next);
        const auto x = mesh.to_vertex_handle(out), y = mesh.to_vertex_handle(next);
        for (const Side& s : sides)
            if (s.valid && (x == s.b || y == s.a)) {
                auto corner = [&s](TriMesh::VertexHandle v) { return v == s.a ? s.at_a : v == s.b ? s.at_b : s.at_w; };
                mesh.property(normal, out) = corner(x);
                mesh.property(normal, next) = corner(y);
                mesh.property(normal, in) = s.mid;
            }
    }
    return m;
}

std::size_t subdivide(Scene& scene, double max_edge, int threads, Finish finish) {
    TriMesh& mesh = scene.mesh;
    const double limit2 = max_edge * max_edge;
    std::size_t splits = 0;
    std::vector<std::pair<double, TriMesh::EdgeHandle>> long_edges;
    for (;;) {
        long_edges.clear();
        for (auto e : mesh.edges()) {
            const double len2 = mesh.calc_edge_sqr_length(e);
            if (len2 > limit2) long_edges.emplace_back(len2, e);
        }
        if (long_edges.empty()) break;
        // Each split adds a vertex and at most three edges and two faces: room for the
        // pass at once, not a reallocation of every mesh property as it grows.
        const std::size_t k = long_edges.size();
        mesh.reserve(mesh.n_vertices() + k, mesh.n_edges() + 3 * k, mesh.n_faces() + 2 * k);
        // Longest first: splitting the longest edge of a triangle is what keeps shapes bounded.
        std::stable_sort(long_edges.begin(), long_edges.end(),
                         [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& [len2, e] : long_edges) {
            // An earlier split in this pass may have shortened this edge (it keeps one half).
            if (mesh.calc_edge_sqr_length(e) <= limit2) continue;
            split_edge(scene, mesh.halfedge_handle(e, 0), 0.5);
            ++splits;
        }
    }
    if (finish == Finish::finalize) scene.finalize(threads);
    return splits;
}

namespace {

// The longest edge of face f, and its squared length.
std::pair<TriMesh::EdgeHandle, double> longest_edge(const TriMesh& mesh, TriMesh::FaceHandle f) {
    std::pair<TriMesh::EdgeHandle, double> best{TriMesh::EdgeHandle(), -1.0};
    for (auto e : mesh.fe_range(f)) {
        const double len2 = mesh.calc_edge_sqr_length(e);
        // Ties broken by index, so that two triangles agree on which is the longest.
        if (len2 > best.second || (len2 == best.second && e.idx() < best.first.idx())) best = {e, len2};
    }
    return best;
}

// One LEPP bisection of face f: its longest edge is split once it is the longest edge of
// the triangle across it too (or on the boundary); until then that triangle is bisected
// first. Along the path the longest edges grow, so it ends; `depth` bounds it anyway.
std::size_t bisect(Scene& scene, TriMesh::FaceHandle f, int depth = 0) {
    TriMesh& mesh = scene.mesh;
    std::size_t splits = 0;
    for (;;) {
        const auto [e, len2] = longest_edge(mesh, f);
        auto h = mesh.halfedge_handle(e, 0);
        if (mesh.face_handle(h) != f) h = mesh.halfedge_handle(e, 1);
        const auto g = mesh.opposite_face_handle(h);
        // Past 64 levels (never seen: along the path the longest edges grow) the edge is
        // split all the same, which gives up the angle bound for that cut.
        if (!g.is_valid() || longest_edge(mesh, g).first == e || depth > 64) {
            split_edge(scene, h, 0.5);
            return splits + 1;
        }
        splits += bisect(scene, g, depth + 1);  // g's cut edges rank above e: look again
    }
}

}  // namespace

std::size_t refine_patches(Scene& scene, const std::vector<double>& max_edge, std::vector<std::uint32_t>* origin,
                           int threads) {
    TriMesh& mesh = scene.mesh;
    if (max_edge.size() != mesh.n_faces())
        throw std::invalid_argument("refine_patches: " + std::to_string(max_edge.size()) + " sizes for " +
                                    std::to_string(mesh.n_faces()) + " patches");
    // Per face, the size its pieces must reach and the patch it came from: face
    // properties, which every split copies to the new faces.
    for (std::size_t i = 0; i < max_edge.size(); ++i)
        if (!(max_edge[i] * max_edge[i] > 0.0))  // also a size so small that its square is 0
            throw std::invalid_argument("refine_patches: patch " + std::to_string(i) + " is given the size " +
                                        std::to_string(max_edge[i]) + " (must be positive)");
    OpenMesh::FPropHandleT<double> limit;
    OpenMesh::FPropHandleT<int> from;
    mesh.add_property(limit);
    mesh.add_property(from);
    for (auto f : mesh.faces()) {
        const double m = max_edge[static_cast<std::size_t>(f.idx())];
        mesh.property(limit, f) = m * m;
        mesh.property(from, f) = f.idx();
    }
    std::size_t splits = 0;
    std::vector<std::pair<double, TriMesh::FaceHandle>> due;
    for (;;) {
        due.clear();
        for (auto f : mesh.faces()) {
            const double len2 = longest_edge(mesh, f).second;
            if (len2 > mesh.property(limit, f)) due.emplace_back(len2, f);
        }
        if (due.empty()) break;
        std::stable_sort(due.begin(), due.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& [len2, f] : due)
            // An earlier bisection in this pass may have cut this face already.
            if (longest_edge(mesh, f).second > mesh.property(limit, f)) splits += bisect(scene, f);
    }
    scene.finalize(threads);
    // Both halves of a split contact edge keep the mark: the count the record shows.
    scene.contact_edges = 0;
    for (auto e : mesh.edges()) scene.contact_edges += mesh.property(scene.contact_edge_handle, e) ? 1 : 0;
    if (origin) {
        origin->clear();
        origin->reserve(mesh.n_faces());
        for (auto f : mesh.faces()) origin->push_back(static_cast<std::uint32_t>(mesh.property(from, f)));
    }
    mesh.remove_property(limit);
    mesh.remove_property(from);
    return splits;
}

void check_refinement(const Scene& scene, double max_edge, const std::string& shown, double max_patches) {
    std::ostringstream size;
    size << max_edge;
    if (!(max_edge > 0.0) || !std::isfinite(max_edge))
        throw SceneError(shown, "patch_size", "must be a positive number, got " + size.str());
    // Per triangle, the pieces its area needs or, for a sliver, its longest edge: a
    // 1000 x 0.001 sliver has little area but is cut along all of its length.
    double estimate = 0.0;
    const auto& pos = scene.vertex_positions();
    for (const auto& p : scene.patch_list()) {
        double longest = 0.0;
        for (int k = 0; k < 3; ++k) longest = std::max(longest, (pos[p.v[k]] - pos[p.v[(k + 1) % 3]]).norm());
        estimate += std::max({1.0, p.area / (0.25 * max_edge * max_edge), longest / max_edge});
    }
    if (estimate > max_patches) {
        std::ostringstream count, limit;
        count << estimate;
        limit.imbue(std::locale::classic());
        limit << std::fixed << std::setprecision(0) << max_patches;
        std::string digits = limit.str();
        for (int k = static_cast<int>(digits.size()) - 3; k > 0; k -= 3) digits.insert(static_cast<std::size_t>(k), ",");
        throw SceneError(shown, "patch_size",
                         size.str() + " would make about " + count.str() + " patches (limit " + digits + ")");
    }
}

}  // namespace raybundle::scenes
