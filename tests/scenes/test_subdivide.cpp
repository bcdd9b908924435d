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
