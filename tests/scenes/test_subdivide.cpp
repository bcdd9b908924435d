// Conforming longest-edge bisection.
#include "scenes/builtin.h"
#include "scenes/subdivide.h"

#include <catch2/catch.hpp>

#include <map>

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
