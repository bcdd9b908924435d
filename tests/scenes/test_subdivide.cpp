// Conforming longest-edge bisection.
#include "scenes/builtin.h"
#include "scenes/subdivide.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <vector>

using namespace raybundle::scenes;

TEST_CASE("subdivision bounds the edges, keeps the area and stays watertight", "[scenes][subdivide]") {
    const double size = GENERATE(0.5, 0.2, 0.07);
    const Scene s = make_builtin("homogeneous-box", size);
    const auto& pos = s.vertex_positions();
    double area = 0.0;
    std::map<std::pair<int, int>, int> edge_uses;
    for (const auto& p : s.patch_list()) {
        area += p.area;
        for (int k = 0; k < 3; ++k) {
            const int a = p.v[k], b = p.v[(k + 1) % 3];
            CHECK((pos[a] - pos[b]).norm() <= size + 1e-12);
            ++edge_uses[{std::min(a, b), std::max(a, b)}];
        }
        // Inward normals: every patch faces the cube's centre.
        CHECK(p.normal.dot(Vec3(0.5, 0.5, 0.5) - p.centroid) > 0.0);
    }
    CHECK(area == Approx(6.0).epsilon(1e-12));
    // Shading normals: the cube's edges are creases, so every corner keeps its patch's
    // normal, to the bit.
    for (std::size_t i = 0; i < s.patch_count(); ++i)
        for (int k = 0; k < 3; ++k) REQUIRE(s.corner_normals()[i][k] == s.patch_list()[i].normal);
    // Closed 2-manifold: every edge is shared by exactly two patches (no T-junctions).
    for (const auto& [edge, uses] : edge_uses) REQUIRE(uses == 2);
}

TEST_CASE("subdivision copies materials to the new patches", "[scenes][subdivide]") {
    const Scene s = make_builtin("cornell-box");
    std::map<int, double> area_by_material;
    for (const auto& p : s.patch_list()) area_by_material[p.material] += p.area;
    const int light = s.find_material("light");
    REQUIRE(light >= 0);
    CHECK(area_by_material[light] == Approx(130.0 * 105.0).epsilon(1e-9));
    CHECK(area_by_material[s.find_material("red")] > 0.0);
    CHECK(area_by_material[s.find_material("green")] > 0.0);
}

namespace {

double smallest_angle(const Scene& s) {
    const auto& pos = s.vertex_positions();
    double least = 3.2;
    for (const auto& p : s.patch_list())
        for (int k = 0; k < 3; ++k) {
            const Vec3 u = pos[p.v[(k + 1) % 3]] - pos[p.v[k]], w = pos[p.v[(k + 2) % 3]] - pos[p.v[k]];
            least = std::min(least, std::acos(std::clamp(u.normalized().dot(w.normalized()), -1.0, 1.0)));
        }
    return least;
}

}  // namespace

namespace {

// subdivide()'s passes done through OpenMesh, one split_edge() at a time: what the fast
// path must reproduce element for element.
std::size_t subdivide_through_openmesh(Scene& s, double max_edge) {
    TriMesh& mesh = s.mesh;
    std::size_t splits = 0;
    std::vector<std::pair<double, TriMesh::EdgeHandle>> long_edges;
    for (;;) {
        long_edges.clear();
        for (auto e : mesh.edges())
            if (mesh.calc_edge_sqr_length(e) > max_edge * max_edge) long_edges.emplace_back(mesh.calc_edge_sqr_length(e), e);
        if (long_edges.empty()) return splits;
        std::stable_sort(long_edges.begin(), long_edges.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& [len2, e] : long_edges) {
            if (mesh.calc_edge_sqr_length(e) <= max_edge * max_edge) continue;
            split_edge(s, mesh.halfedge_handle(e, 0), 0.5);
            ++splits;
        }
    }
}

// Every handle, point, corner normal, contact mark, material, object and status the same.
void require_same_mesh(const Scene& a, const Scene& b) {
    const TriMesh &m = a.mesh, &n = b.mesh;
    REQUIRE(m.n_vertices() == n.n_vertices());
    REQUIRE(m.n_edges() == n.n_edges());
    REQUIRE(m.n_faces() == n.n_faces());
    std::size_t differ = 0;
    for (auto h : m.halfedges()) {
        const TriMesh::HalfedgeHandle g(h.idx());
        differ += m.to_vertex_handle(h) != n.to_vertex_handle(g) || m.next_halfedge_handle(h) != n.next_halfedge_handle(g) ||
                  m.prev_halfedge_handle(h) != n.prev_halfedge_handle(g) || m.face_handle(h) != n.face_handle(g) ||
                  m.property(a.corner_normal_handle, h) != n.property(b.corner_normal_handle, g);
    }
    for (auto v : m.vertices()) {
        const TriMesh::VertexHandle w(v.idx());
        differ += m.halfedge_handle(v) != n.halfedge_handle(w) || m.point(v) != n.point(w) ||
                  m.status(v).bits() != n.status(w).bits();
    }
    for (auto e : m.edges()) {
        const TriMesh::EdgeHandle g(e.idx());
        differ += m.property(a.contact_edge_handle, e) != n.property(b.contact_edge_handle, g) ||
                  m.status(e).bits() != n.status(g).bits();
    }
    for (auto f : m.faces()) {
        const TriMesh::FaceHandle g(f.idx());
        differ += m.halfedge_handle(f) != n.halfedge_handle(g) || m.property(a.material_handle, f) != n.property(b.material_handle, g) ||
                  m.property(a.object_handle, f) != n.property(b.object_handle, g) || m.status(f).bits() != n.status(g).bits();
    }
    REQUIRE(differ == 0);
}

// A bent open strip (boundary edges, smooth corner normals across its fold) beside a
// closed box, with a few contact edges marked: what refinement must carry.
Scene strip_and_box() {
    Scene s;
    Material m;
    m.name = "grey";
    m.albedo = Rgb::Constant(0.5);
    const int grey = s.add_material(m);
    std::vector<Vec3> v;
    std::vector<std::array<int, 3>> t;
    for (int i = 0; i <= 4; ++i) {
        const double x = 0.7 * i, z = 0.4 * std::sin(0.6 * i);
        v.emplace_back(x, 0.0, z);
        v.emplace_back(x, 1.3, z + 0.1);
    }
    for (int i = 0; i < 4; ++i) {
        t.push_back({2 * i, 2 * i + 2, 2 * i + 1});
        t.push_back({2 * i + 1, 2 * i + 2, 2 * i + 3});
    }
    s.add_object(v, t, grey, "strip");
    const Vec3 lo(0.5, 2.0, -0.5), hi(1.6, 2.9, 0.7);
    const std::vector<Vec3> c = {{lo.x(), lo.y(), lo.z()}, {hi.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), lo.z()},
                                 {lo.x(), hi.y(), lo.z()}, {lo.x(), lo.y(), hi.z()}, {hi.x(), lo.y(), hi.z()},
                                 {hi.x(), hi.y(), hi.z()}, {lo.x(), hi.y(), hi.z()}};
    const std::vector<std::array<int, 3>> box = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                                 {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    s.add_object(c, box, grey, "box");
    s.finalize();
    int k = 0;
    for (auto e : s.mesh.edges())
        if (k++ % 5 == 0) s.mesh.property(s.contact_edge_handle, e) = true;
    return s;
}

}  // namespace

TEST_CASE("subdivision's own split arrays give OpenMesh's splits element for element, on any number of threads",
          "[scenes][subdivide]") {
    struct Case {
        const char* name;
        Scene coarse;
        double size;
    };
    std::vector<Case> cases;
    cases.push_back({"homogeneous box", make_builtin("homogeneous-box", 10.0), 0.09});
    // Cut at its contacts first: marked edges and their vertices, split again.
    cases.push_back({"Cornell box", make_builtin("cornell-box", 1e4), 20.0});  // passes of over 4,096 splits: on the threads
    cases.push_back({"open strip and box", strip_and_box(), 0.11});
    cases.push_back({"open strip and box, finer: boundary links on the threads", strip_and_box(), 0.03});
    for (const Case& c : cases) {
        INFO(c.name);
        Scene reference = c.coarse;
        const std::size_t splits = subdivide_through_openmesh(reference, c.size);
        REQUIRE(splits > 100);
        for (const int threads : {1, 3}) {
            INFO(threads << " threads");
            Scene fast = c.coarse;
            REQUIRE(subdivide(fast, c.size, threads, Finish::leave_mesh) == splits);
            require_same_mesh(fast, reference);
            // The flat arrays made from it are the same too.
            Scene expected = reference;
            fast.finalize(threads);
            expected.finalize();
            REQUIRE(fast.patch_count() == expected.patch_count());
            std::size_t differ = 0;
            for (std::size_t i = 0; i < fast.patch_count(); ++i)
                differ += !std::equal(fast.patch_list()[i].v, fast.patch_list()[i].v + 3, expected.patch_list()[i].v) ||
                          fast.corner_normals()[i] != expected.corner_normals()[i];
            REQUIRE(differ == 0);
        }
    }
}

TEST_CASE("refine_patches cuts the chosen patches, stays watertight, and keeps every piece's origin",
          "[scenes][subdivide]") {
    const Scene coarse = make_builtin("homogeneous-box", 0.25);
    Scene s = coarse;
    // A corner of the floor to 0.05, the rest as it is.
    std::vector<double> sizes(coarse.patch_count(), std::numeric_limits<double>::infinity());
    std::size_t chosen = 0;
    for (std::size_t i = 0; i < coarse.patch_count(); ++i) {
        const auto& c = coarse.patch_list()[i].centroid;
        if (c.y() < 1e-9 && c.x() < 0.3 && c.z() < 0.3) sizes[i] = 0.05, ++chosen;
    }
    REQUIRE(chosen > 0);
    std::vector<std::uint32_t> origin;
    const std::size_t splits = refine_patches(s, sizes, &origin);
    REQUIRE(origin.size() == s.patch_count());
    CHECK(splits > 0);
    // Far fewer patches than the whole box at 0.05.
    CHECK(s.patch_count() < make_builtin("homogeneous-box", 0.05).patch_count() / 4);
    const auto& pos = s.vertex_positions();
    std::vector<double> area_of(coarse.patch_count(), 0.0);
    std::vector<int> pieces(coarse.patch_count(), 0);
    std::map<std::pair<int, int>, int> edge_uses;
    for (std::size_t i = 0; i < s.patch_count(); ++i) {
        const auto& p = s.patch_list()[i];
        const std::uint32_t o = origin[i];
        REQUIRE(o < coarse.patch_count());
        area_of[o] += p.area;
        ++pieces[o];
        CHECK(p.material == coarse.patch_list()[o].material);
        CHECK(p.normal.dot(coarse.patch_list()[o].normal) == Approx(1.0));
        for (int k = 0; k < 3; ++k) {
            const int a = p.v[k], b = p.v[(k + 1) % 3];
            if (std::isfinite(sizes[o])) CHECK((pos[a] - pos[b]).norm() <= sizes[o] * (1 + 1e-12));
            ++edge_uses[{std::min(a, b), std::max(a, b)}];
        }
    }
    // Every piece lies in its patch: the pieces' areas add up to it.
    for (std::size_t o = 0; o < coarse.patch_count(); ++o) REQUIRE(area_of[o] == Approx(coarse.patch_list()[o].area).epsilon(1e-12));
    // No T-junctions.
    for (const auto& [edge, uses] : edge_uses) REQUIRE(uses == 2);
    // The ceiling, away from the corner, is untouched.
    for (std::size_t o = 0; o < coarse.patch_count(); ++o)
        if (coarse.patch_list()[o].centroid.y() > 1.0 - 1e-9) CHECK(pieces[o] == 1);
    // Longest-edge bisection keeps the angles: at least half the coarse mesh's smallest.
    CHECK(smallest_angle(s) >= 0.5 * smallest_angle(coarse));

    // Nothing chosen: nothing changes.
    Scene same = coarse;
    CHECK(refine_patches(same, std::vector<double>(coarse.patch_count(), std::numeric_limits<double>::infinity())) == 0);
    CHECK(same.patch_count() == coarse.patch_count());
    // One size per patch, each positive.
    CHECK_THROWS_AS(refine_patches(same, {1.0}), std::invalid_argument);
    std::vector<double> zero(coarse.patch_count(), 1.0);
    zero[3] = 0.0;
    CHECK_THROWS_WITH(refine_patches(same, zero), Catch::Contains("patch 3") && Catch::Contains("positive"));
}
