// Direct light at the gather's hits (render/gather_estimator.h, GatherOptions::
// direct_at_hits): where a hard shadow crosses coarse patches, the gather's indirect
// light against an exact quadrature, with the field read whole and with the direct
// light taken at the hit point.
#include "render/gather_estimator.h"
#include "scenes/loader.h"
#include "solver/solver.h"
#include "solver/transport.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;

namespace {

// A wall (z = 0, facing +z, albedo 0.8) in coarse patches, lit from above and in front
// by a small lamp (an area light, or a point light at its centre); a black plate
// between them throws a slanted hard shadow across the wall; a small black receiver
// faces the wall from z = 0.5, in front of the shadow's edge. Nothing but the wall reflects, and the wall cannot see
// itself: its radiance is its direct light, reflected, and the receiver's incident
// indirect light is that radiance's integral over the wall.
scenes::Scene shadowed_wall(bool point_light, bool both = false) {
    const std::string area = R"(, {"quad": [[-0.2, 2, 0.4], [0.2, 2, 0.4], [0.2, 2, 0.8], [-0.2, 2, 0.8]],
                                   "material": "lamp"})";
    const std::string point = R"("point_lights": [{"position": [0, 2, 0.6], "intensity": [3, 3, 3]}],)";
    const std::string lamp = both ? area + "], " + point : point_light ? "], " + point : area + "],";
    const std::string text = R"({
      "camera": {"eye": [0, 0.5, 3], "target": [0, 0.5, 0], "fov_y": 60, "width": 8, "height": 8},
      "materials": {"wall": {"albedo": [0.8, 0.8, 0.8]}, "black": {"albedo": [0, 0, 0]},
                    "lamp": {"albedo": [0, 0, 0], "emission": [20, 20, 20]}},
      "objects": [
        {"quad": [[-1, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 1, 0]], "material": "wall"},
        {"quad": [[-1.5, 1.4, 0], [-1.5, 1.4, 1], [0.2, 1.4, 1], [0.2, 1.4, 0]], "material": "black"},
        {"quad": [[0.45, 0.25, 0.5], [0.45, 0.35, 0.5], [0.55, 0.35, 0.5], [0.55, 0.25, 0.5]], "material": "black"})" +
                             lamp + R"( "patch_size": 1, "cut_contacts": false})";
    return scenes::parse_scene(text, "shadowed-wall.json", ".");
}

// The exact incident radiance at x (normal n) from the wall, cosine-weighted (its
// irradiance over pi, what GatherEstimator::indirect estimates): the midpoint rule on a
// wx x wy grid of the wall, each point's direct light by the midpoint rule on 12 x 12
// points of the lamp (or the point light). Visibility is exact: the plate (y = 1.4,
// -1.5 <= x <= 0.2, 0 <= z <= 1) is all that stands between the lamp and the wall, and
// nothing between the wall and x.
double exact_incident(const scenes::Scene& s, const Vec3& x, const Vec3& n, bool point_light, int wx, int wy) {
    auto seen = [](const Vec3& y, const Vec3& p) {
        const Vec3 c = y + (1.4 - y.y()) / (p.y() - y.y()) * (p - y);
        return !(c.x() >= -1.5 && c.x() <= 0.2 && c.z() >= 0.0 && c.z() <= 1.0);
    };
    const int l = 12;
    const double dA = 2.0 * 1.0 / (wx * wy), dL = 0.4 * 0.4 / (l * l);
    double E = 0.0;
    for (int j = 0; j < wy; ++j)
        for (int i = 0; i < wx; ++i) {
            const Vec3 y(-1.0 + 2.0 * (i + 0.5) / wx, (j + 0.5) / wy, 0.0);
            const Vec3 to_x = x - y;
            const double r2 = to_x.squaredNorm();
            const double cos_y = to_x.z() / std::sqrt(r2), cos_x = -n.dot(to_x) / std::sqrt(r2);
            if (cos_y <= 0.0 || cos_x <= 0.0) continue;
            double direct = 0.0;  // irradiance at y
            if (point_light) {
                const Vec3 p = s.point_lights[0].position, d = p - y;
                if (seen(y, p)) direct = 3.0 * d.z() / std::pow(d.norm(), 3);
            } else {
                for (int b = 0; b < l; ++b)
                    for (int a = 0; a < l; ++a) {
                        const Vec3 p(-0.2 + 0.4 * (a + 0.5) / l, 2.0, 0.4 + 0.4 * (b + 0.5) / l), d = p - y;
                        const double r_2 = d.squaredNorm();
                        // cos at y: d.z / r; at the lamp (facing -y): d.y / r.
                        if (seen(y, p)) direct += 20.0 * d.z() * d.y() / (r_2 * r_2) * dL;
                    }
            }
            E += 0.8 / M_PI * direct * cos_x * cos_y / r2 * dA;
        }
    return E / M_PI;
}

}  // namespace

TEST_CASE("final gather: direct light taken at the hits keeps a hard shadow's edge that coarse patches blur",
          "[render][gather][contacts]") {
    const bool point_light = GENERATE(false, true);
    INFO((point_light ? "a point light (the first shot)" : "an area light (the diffuse shot)"));
    const scenes::Scene s = shadowed_wall(point_light);
    const scenes::RayCaster caster(s);
    // The solved field: with no light between surfaces, a few steps give it exactly.
    const solver::Transport transport(s, solver::ShotOptions{!point_light});
    solver::SolverOptions so;
    so.steps = 4;
    auto solver = solver::make_solver(transport, so, {});
    solver->run();
    const solver::RadianceField field = solver->field();
    REQUIRE(field.direct.size() == s.patch_count());

    std::size_t receiver = s.patch_count();
    for (std::size_t p = 0; p < s.patch_count(); ++p)
        if (std::abs(s.patch_list()[p].centroid.z() - 0.5) < 1e-9 && s.patch_list()[p].centroid.y() < 1.0) receiver = p;
    REQUIRE(receiver < s.patch_count());
    const Vec3 x(0.5, 0.3, 0.5), n(0, 0, -1);
    const double exact = exact_incident(s, x, n, point_light, 240, 120);

    auto gathered = [&](bool at_hits, long& marked) {
        render::GatherOptions o;
        o.near_hits = false;
        o.direct_at_hits = at_hits;
        const render::GatherEstimator g(s, caster, field, o);
        marked = g.direct_at_hits();
        sampling::Rng rng(7);
        long rays = 0;
        double sum = 0.0;
        const int calls = 32;
        for (int k = 0; k < calls; ++k) sum += g.indirect(receiver, x, n, n, 4096, rng, rays)[0];
        return sum / calls;
    };
    long marked_on = 0, marked_off = 0;
    const double on = gathered(true, marked_on), off = gathered(false, marked_off);
    INFO("exact " << exact << ", at the hits " << on << " (" << marked_on << " patches), field read whole " << off);
    // The wall's patches the shadow crosses, and those beside them; not the whole wall.
    CHECK(marked_off == -1);
    CHECK(marked_on >= 2);
    long wall = 0;
    for (std::size_t p = 0; p < s.patch_count(); ++p) wall += s.material_of(p).name == "wall";
    CHECK(marked_on < wall);
    CHECK(on == Approx(exact).epsilon(0.01));
    // The field's patch averages, smoothed to the corners, carry light into the shadow.
    CHECK(std::abs(off / exact - 1.0) > 0.03);
}

TEST_CASE("final gather: no direct light at the hits where the field does not keep all of it apart",
          "[render][gather]") {
    // Point lights and an area light: without the diffuse shot the area light's direct
    // light moves through the iteration, and the first shot's part alone is no stand-in
    // for what a hit point's estimate (of every light) replaces.
    const scenes::Scene s = shadowed_wall(false, true);
    const scenes::RayCaster caster(s);
    for (const bool diffuse_shot : {false, true}) {
        INFO("diffuse shot " << diffuse_shot);
        const solver::Transport transport(s, solver::ShotOptions{diffuse_shot});
        solver::SolverOptions so;
        so.steps = 2;
        auto solver = solver::make_solver(transport, so, {});
        solver->run();
        const solver::RadianceField field = solver->field();
        CHECK(field.direct.size() == (diffuse_shot ? s.patch_count() : 0));
        const render::GatherEstimator g(s, caster, field, render::GatherOptions{});
        CHECK((g.direct_at_hits() > 0) == diffuse_shot);
        CHECK((g.direct_at_hits() == -1) == !diffuse_shot);
    }
}
