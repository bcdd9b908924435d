// Area lights (render/lights.h): Lambert's polygon formula against closed forms and
// Monte Carlo, the boundary-only sum against the sum over triangles, clipping.
#include "render/lights.h"
#include "sampling/rng.h"
#include "scenes/builtin.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include <vector>

using namespace raybundle;
using render::AreaLights;
using scenes::Vec3;

namespace {

// Monte Carlo projected solid angle of triangle (a, b, c) seen from x, normal n:
// uniform points y on the triangle, cos_x cos_y / r^2 * area, front side only.
double monte_carlo(const Vec3& x, const Vec3& n, const Vec3& a, const Vec3& b, const Vec3& c, int samples) {
    sampling::Rng rng(7, 0);
    const Vec3 cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    const Vec3 front = cross.normalized();
    double sum = 0.0;
    for (int i = 0; i < samples; ++i) {
        const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
        const Vec3 y = (1 - r1) * a + r1 * (1 - r2) * b + r1 * r2 * c;
        const Vec3 d = y - x;
        const double r2n = d.squaredNorm();
        const Vec3 w = d / std::sqrt(r2n);
        const double cx = n.dot(w), cy = -front.dot(w);
        if (cx > 0 && cy > 0) sum += cx * cy / r2n;
    }
    return sum * area / samples;
}

// A lamp at z = 2 facing -z: a 6 x 6 grid of cells of 0.5 (two triangles each) with a
// hole of 2 x 2 cells and a corner notch of 2 x 2: its outline is two loops, an L-shaped
// hexagon and a square, which a plane crosses up to six times.
scenes::Scene holed_lamp() {
    scenes::Scene lamp;
    scenes::Material m;
    m.name = "lamp";
    m.emission = scenes::Rgb::Constant(2.0);
    const int l = lamp.add_material(m);
    std::vector<Vec3> v;
    std::vector<std::array<int, 3>> t;
    for (int b = 0; b <= 6; ++b)
        for (int a = 0; a <= 6; ++a) v.emplace_back(-1.5 + 0.5 * a, -1.5 + 0.5 * b, 2.0);
    for (int b = 0; b < 6; ++b)
        for (int a = 0; a < 6; ++a) {
            if (((a == 2 || a == 3) && (b == 2 || b == 3)) || (a >= 4 && b >= 4)) continue;  // hole, notch
            const int k = b * 7 + a;
            t.push_back({k, k + 7, k + 8});  // facing -z
            t.push_back({k, k + 8, k + 1});
        }
    lamp.add_object(v, t, l, "lamp");
    lamp.finalize();
    return lamp;
}

}  // namespace

TEST_CASE("projected solid angle: a square over a point (closed form)", "[render][lights]") {
    // A square of side 2s at height h centred over x, facing down: the unoccluded
    // point-to-square form factor times pi (Hottel): 4 * s / sqrt(h^2+s^2) * atan(s / sqrt(h^2+s^2)).
    const double s = 0.7, h = 1.3;
    const Vec3 x(0, 0, 0), n(0, 0, 1);
    const Vec3 p0(-s, -s, h), p1(s, -s, h), p2(s, s, h), p3(-s, s, h);
    // Counter-clockwise about the downward normal: p0, p3, p2, p1.
    const double omega = AreaLights::projected_solid_angle(x, n, p0, p3, p2) +
                         AreaLights::projected_solid_angle(x, n, p0, p2, p1);
    const double q = std::sqrt(h * h + s * s);
    const double exact = 4.0 * s / q * std::atan(s / q);
    CHECK(omega == Approx(exact).epsilon(1e-12));
    // The back side gives nothing.
    CHECK(AreaLights::projected_solid_angle(x, n, p0, p2, p3) == 0.0);
}

TEST_CASE("projected solid angle: clipped triangles against Monte Carlo", "[render][lights]") {
    // Triangles cut by the receiver's plane, tilted receivers, a receiver on the far side.
    sampling::Rng rng(3, 1);
    int checked = 0;
    for (int t = 0; t < 40; ++t) {
        auto rnd = [&]() -> Vec3 { return Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5) * 2.0; };
        const Vec3 a = rnd() + Vec3(0, 0, 1), b = rnd() + Vec3(0, 0, 1), c = rnd() + Vec3(0, 0, 1);
        const Vec3 n = (rnd() + Vec3(0, 0, 1.2)).normalized();
        const Vec3 x = 0.3 * rnd();
        const double exact = AreaLights::projected_solid_angle(x, n, a, b, c);
        const double mc = monte_carlo(x, n, a, b, c, 400000);
        INFO("triangle " << t << ": exact " << exact << ", Monte Carlo " << mc);
        CHECK(exact >= 0.0);
        CHECK(std::abs(exact - mc) <= 0.01 * std::max(mc, 0.05));
        if (exact > 0.0) ++checked;
    }
    CHECK(checked >= 10);
}

TEST_CASE("area lights: the boundary sum equals the sum over the light's triangles", "[render][lights]") {
    // Lights of many patches: the Cornell box's panel refined, and holed_lamp(). The
    // irradiance from the boundary alone (clipped where x's plane cuts the light)
    // equals the sum over the triangles clipped one by one, from random points and
    // normals, most of them cutting the light.
    const scenes::Scene lamp = holed_lamp();
    const auto box = scenes::make_builtin("cornell-box", 20.0);
    for (const scenes::Scene* scene : std::array<const scenes::Scene*, 2>{&box, &lamp}) {
        const AreaLights lights(*scene);
        REQUIRE(lights.light_count() == 1);
        REQUIRE(lights.patch_count() > 8);
        const auto& pos = scene->vertex_positions();
        // Points within twice the light's size of its centre, in front of it.
        Vec3 centre = Vec3::Zero(), front = Vec3::Zero();
        double size = 0.0;
        int corners = 0;
        for (std::size_t j = 0; j < scene->patch_count(); ++j)
            if (lights.probability(j) > 0.0)
                for (int v : scene->patch_list()[j].v) centre += pos[v], ++corners, front = scene->patch_list()[j].normal;
        centre /= corners;
        for (std::size_t j = 0; j < scene->patch_count(); ++j)
            if (lights.probability(j) > 0.0)
                for (int v : scene->patch_list()[j].v) size = std::max(size, (pos[v] - centre).norm());
        sampling::Rng rng(5, 2);
        int cut = 0;
        for (int t = 0; t < 400; ++t) {
            Vec3 x = centre + 2.0 * size * Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5);
            if (front.dot(x - centre) < 0.0) x -= 2.0 * front.dot(x - centre) * front;
            const Vec3 n = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5).normalized();
            double per_triangle = 0.0;
            int above = 0, below = 0;
            for (std::size_t j = 0; j < scene->patch_count(); ++j) {
                if (lights.probability(j) <= 0.0) continue;
                const auto& p = scene->patch_list()[j];
                per_triangle += scene->material_of(j).emission[0] *
                                AreaLights::projected_solid_angle(x, n, pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]);
                for (int v : p.v) (n.dot(pos[v] - x) > 0.0 ? above : below) += 1;
            }
            if (above > 0 && below > 0 && per_triangle > 0.0) ++cut;
            CHECK(lights.irradiance(x, n)[0] == Approx(per_triangle).epsilon(1e-9).margin(1e-12));
        }
        INFO((scene == &lamp ? "the lamp" : "the Cornell box") << ": " << cut << " of 400 points' planes cut the light");
        CHECK(cut > 100);
    }
}

TEST_CASE("area lights: receivers whose plane runs through the light's corners, and receivers next to its plane",
          "[render][lights]") {
    // The outline's clipping counts a corner on x's plane as behind it (a cut at the
    // corner itself) and an edge along the plane as no edge, where the triangles clipped
    // one by one keep both (AreaLights::projected_solid_angle): the two must agree. And a
    // receiver a hair below the light sees its outline's edges at angles near pi.
    const scenes::Scene lamp = holed_lamp();  // z = 2, facing -z, corners on a grid of 0.5
    const AreaLights lights(lamp);
    const auto& pos = lamp.vertex_positions();
    auto per_triangle = [&](const Vec3& x, const Vec3& n) {
        double sum = 0.0;
        for (std::size_t j = 0; j < lamp.patch_count(); ++j) {
            const auto& p = lamp.patch_list()[j];
            sum += 2.0 * AreaLights::projected_solid_angle(x, n, pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]);
        }
        return sum;
    };
    std::vector<std::uint32_t> lit_patches(lamp.patch_count());
    for (std::size_t j = 0; j < lit_patches.size(); ++j) lit_patches[j] = static_cast<std::uint32_t>(j);
    std::vector<Vec3> corners;  // the outline's (straight runs joined: where it turns)
    for (const auto& [a, b] : scenes::plane_outline(lamp, lit_patches)) corners.push_back(pos[a]);
    REQUIRE(corners.size() == 10);
    sampling::Rng rng(11, 3);
    int on_plane = 0, lit = 0;
    // Planes x = c, y = c and x +- y = c through rows, columns and diagonals of corners:
    // the offsets below are multiples of 1/64, so that n . (corner - x) is exactly 0.
    for (int t = 0; t < 600; ++t) {
        const double c = -1.5 + 0.5 * std::floor(7.0 * rng.uniform()), s = std::floor(64.0 * rng.uniform() - 32.0) / 64.0;
        const double h = 2.0 - 0.05 - 2.0 * rng.uniform(), k = 1.0 / std::sqrt(2.0);
        const double sign = rng.uniform() < 0.5 ? 1.0 : -1.0;
        Vec3 x, n;
        switch (t % 4) {
            case 0: x = Vec3(c, s, h), n = Vec3(sign, 0.0, 0.0); break;
            case 1: x = Vec3(s, c, h), n = Vec3(0.0, sign, 0.0); break;
            case 2: x = Vec3(c + s, c - s, h), n = Vec3(sign * k, sign * k, 0.0); break;
            default: x = Vec3(c + s, s - c, h), n = Vec3(sign * k, -sign * k, 0.0); break;
        }
        int touching = 0;
        for (const auto& v : corners) touching += n.dot(v - x) == 0.0;
        on_plane += touching > 0;
        const double expected = per_triangle(x, n);
        lit += expected > 0.0;
        CHECK(lights.irradiance(x, n)[0] == Approx(expected).epsilon(1e-9).margin(1e-12));
    }
    INFO(on_plane << " of 600 receivers' planes run through corners of the light's outline, " << lit
                   << " see some of it");
    CHECK(on_plane > 300);
    CHECK(lit > 300);
    // Receivers 1e-8 to 1e-2 below the light (its guard is 1e-9 of the scene's size),
    // under it, its hole and its notch, with random normals.
    for (int t = 0; t < 400; ++t) {
        const double d = std::pow(10.0, -8.0 + 6.0 * rng.uniform());
        const Vec3 x(3.4 * rng.uniform() - 1.7, 3.4 * rng.uniform() - 1.7, 2.0 - d);
        const Vec3 n = Vec3(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5).normalized();
        CHECK(lights.irradiance(x, n)[0] == Approx(per_triangle(x, n)).epsilon(1e-9).margin(1e-12));
    }
}

TEST_CASE("a plane's outline: straight runs of edges are one edge", "[render][lights]") {
    // The Cornell box's light panel at patch size 10 (1,024 patches) is a rectangle; the
    // holed lamp an L-shaped hexagon and a square hole. Each edge of the outline turns
    // at both ends, and the outlines run counter-clockwise about the lights' normals.
    const auto box = scenes::make_builtin("cornell-box", 10.0), lamp = holed_lamp();
    for (const auto& [scene, corners] : {std::pair{&box, 4}, std::pair{&lamp, 10}}) {
        std::vector<std::uint32_t> lit;
        for (std::size_t j = 0; j < scene->patch_count(); ++j)
            if (scene->material_of(j).emissive()) lit.push_back(static_cast<std::uint32_t>(j));
        REQUIRE(lit.size() > 50);
        const auto outline = scenes::plane_outline(*scene, lit);
        CHECK(static_cast<int>(outline.size()) == corners);
        const auto& pos = scene->vertex_positions();
        const Vec3 normal = scene->patch_list()[lit.front()].normal;
        double area = 0.0, light = 0.0;  // the outline's signed area about the normal, and the patches'
        for (const auto& [a, b] : outline) area += 0.5 * normal.dot(pos[a].cross(pos[b]));
        for (const std::uint32_t j : lit) light += scene->patch_list()[j].area;
        CHECK(area == Approx(light).epsilon(1e-12));
        for (const auto& [a, b] : outline) {  // each edge meets the next one at an angle
            std::size_t next = 0;
            for (std::size_t e = 0; e < outline.size(); ++e)
                if (outline[e].first == b) next = e;
            const Vec3 d1 = pos[b] - pos[a], d2 = pos[outline[next].second] - pos[b];
            CHECK(d1.cross(d2).norm() > 0.1 * d1.norm() * d2.norm());
        }
    }
}

TEST_CASE("area lights: a pick lands on the patch a sorted search of the distribution gives", "[render][lights]") {
    // sample() and sample_light() look a pick up from a table of cells; the answer must be
    // std::upper_bound's over the whole distribution, also for picks on and next to its
    // steps and at the cells' bounds.
    // A strip of 2,000 triangles of random widths: steps of every size.
    scenes::Scene scene;
    {
        scenes::Material m;
        m.name = "strip";
        m.emission = scenes::Rgb::Constant(1.0);
        const int l = scene.add_material(m);
        sampling::Rng widths(9, 4);
        std::vector<Vec3> v;
        std::vector<std::array<int, 3>> t;
        double x = 0.0;
        for (int k = 0; k <= 1000; ++k, x += 0.01 + widths.uniform()) {
            v.emplace_back(x, 0.0, 0.0);
            v.emplace_back(x, 1.0, 0.0);
        }
        for (int k = 0; k < 1000; ++k) {
            t.push_back({2 * k, 2 * k + 2, 2 * k + 1});
            t.push_back({2 * k + 1, 2 * k + 2, 2 * k + 3});
        }
        scene.add_object(v, t, l, "strip");
        scene.finalize();
    }
    const AreaLights lights(scene);
    REQUIRE(lights.light_count() == 1);
    std::vector<std::uint32_t> emitters;
    std::vector<double> cdf, area_cdf;
    double power = 0.0, area = 0.0;
    for (std::size_t j = 0; j < scene.patch_count(); ++j)
        if (lights.probability(j) > 0.0) {
            emitters.push_back(static_cast<std::uint32_t>(j));
            cdf.push_back(power += lights.probability(j));
            area_cdf.push_back(area += scene.patch_list()[j].area);
        }
    REQUIRE(emitters.size() == 2000);
    for (auto& c : area_cdf) c /= area;
    std::vector<double> picks;
    sampling::Rng rng(3, 1);
    for (int k = 0; k < 20000; ++k) picks.push_back(rng.uniform());
    for (const auto* steps : {&cdf, &area_cdf})
        for (const double c : *steps)
            for (const double u : {c, std::nextafter(c, 0.0), std::nextafter(c, 1.0)})
                if (u >= 0.0 && u < 1.0) picks.push_back(u);
    for (std::size_t c = 0; c <= emitters.size(); ++c) {
        const double u = static_cast<double>(c) / static_cast<double>(emitters.size());
        for (const double v : {u, std::nextafter(u, 0.0), std::nextafter(u, 1.0)})
            if (v >= 0.0 && v < 1.0) picks.push_back(v);
    }
    picks.push_back(0.0);
    auto expected = [&](const std::vector<double>& values, double u) {
        return std::min<std::size_t>(
            static_cast<std::size_t>(std::upper_bound(values.begin(), values.end(), u) - values.begin()),
            values.size() - 1);
    };
    std::size_t wrong = 0, far = 0;
    for (const double u : picks) {
        // The light's area distribution as AreaLights sums it: exactly its answer.
        if (lights.sample_light(0, u, 0.3, 0.6).patch != emitters[expected(area_cdf, u)]) ++wrong;
        // The power's, which AreaLights normalises in its own order: a pick on a step
        // may fall to either side of it.
        const auto got = static_cast<long>(lights.sample(u, 0.3, 0.6).patch), want = static_cast<long>(emitters[expected(cdf, u)]);
        if (std::abs(got - want) > 1) ++far;
    }
    INFO(picks.size() << " picks");
    CHECK(wrong == 0);
    CHECK(far == 0);
}
