// The first shot (point, spot and directional lights, 004 section 9) and the sky (section 6) against
// closed-form answers.
#include "reference.h"
#include "render/lights.h"
#include "sampling/run.h"
#include "scenes/builtin.h"
#include "scenes/loader.h"
#include "scenes/ray_caster.h"
#include "scenes/scene.h"
#include "scenes/subdivide.h"
#include "solver/first_shot.h"
#include "solver/form_factor.h"
#include "solver/global_walks.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <array>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <vector>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;
using testing::triangle_mean;

namespace {

// A square plane z = 0 of side 2 centred at the origin, facing +z, albedo rho.
scenes::Scene plane(double rho, double patch_size) {
    scenes::Scene s;
    scenes::Material m;
    m.name = "ground";
    m.albedo = Rgb::Constant(rho);
    const int mat = s.add_material(m);
    s.add_object({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, mat);
    s.finalize();
    scenes::subdivide(s, patch_size);
    s.camera.eye = Vec3(0, -3, 2);
    s.camera.target = Vec3(0, 0, 0);
    s.camera.up = Vec3(0, 0, 1);
    return s;
}

// Adds a square of half side h at height z over the plane, facing up (its back, below,
// black), and finalizes the scene.
void add_square(scenes::Scene& scene, double h, double z) {
    scenes::Material occ;
    occ.name = "occluder";
    occ.albedo = Rgb::Constant(0.5);
    const int m = scene.add_material(occ);
    scene.add_object({{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}}, {{{0, 1, 2}}, {{0, 2, 3}}}, m);
    scene.finalize();
}

solver::FirstShot shoot(const scenes::Scene& scene) {
    const scenes::RayCaster caster(scene);
    return solver::first_shot(scene, caster);
}

solver::RadianceField iterate(const scenes::Scene& scene, const std::string& backend_name, long steps,
                              std::uint64_t seed = 1) {
    visibility::BackendOptions bo;
    bo.sky = scene.sky.has_value();
    auto backend = visibility::make_backend(backend_name, scene, bo);
    solver::SolverOptions opt;
    sampling::RunOptions opt_run;
    opt.steps = steps;
    opt_run.seed = seed;
    solver::StochasticIteration it(scene, *backend, opt, opt_run);
    it.run();
    return it.field();
}

}  // namespace

TEST_CASE("point light over a plane: radiance = rho I cos / (pi r^2), patch-averaged, within 1 %",
          "[solver][first-shot]") {
    const double rho = 0.6;
    auto scene = plane(rho, 0.15);
    const Vec3 light(0.2, -0.1, 0.5);
    const Rgb intensity(4.0, 2.0, 1.0);
    scene.point_lights.push_back({light, intensity});
    const solver::Transport transport(scene);
    CHECK(transport.shot_stats().lights == 1);
    CHECK(transport.shot_stats().shadow_rays > 0);
    // Nothing else in the scene: the plane cannot see itself, so the iteration adds
    // nothing to the first shot.
    const auto field = iterate(scene, "painter", 20);
    const auto& pos = scene.vertex_positions();
    double worst = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        const double e = triangle_mean({pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]}, 6, [&](const Vec3& x) {
            const Vec3 d = light - x;
            return d.z() / d.norm() / d.squaredNorm();
        });
        for (int c = 0; c < 3; ++c) {
            const double exact = rho * intensity[c] * e / M_PI;
            worst = std::max(worst, std::abs(field.radiance[i][c] / exact - 1.0));
        }
    }
    INFO("worst relative deviation " << worst);
    CHECK(worst < 0.01);
}

TEST_CASE("spot light over a plane: its cone and fall-off, patch-averaged, within 1 %", "[solver][first-shot]") {
    // A spot 0.5 above the plane aimed straight down, tilted a little: full within 20
    // degrees of its axis, nothing past 40, glTF's ramp between (the ground under it is
    // lit out to a radius of 0.42, the plane's edge at 1 stays dark).
    const double rho = 0.6;
    auto scene = plane(rho, 0.1);
    scenes::PointLight spot;
    spot.position = Vec3(0.1, 0.05, 0.5);
    spot.intensity = Rgb(4.0, 2.0, 1.0);
    spot.axis = Vec3(0.1, 0.0, -1.0).normalized();
    spot.cos_inner = std::cos(20.0 * M_PI / 180.0);
    spot.cos_outer = std::cos(40.0 * M_PI / 180.0);
    scene.point_lights.push_back(spot);
    const auto field = iterate(scene, "painter", 20);
    const auto& pos = scene.vertex_positions();
    double worst = 0.0, dark = 0.0, sum = 0.0, exact_sum = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        const double e = triangle_mean({pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]}, 7, [&](const Vec3& x) {
            const Vec3 d = spot.position - x;
            return spot.falloff(-d.normalized()) * d.z() / d.norm() / d.squaredNorm();
        });
        const double exact = rho * spot.intensity[0] * e / M_PI;
        sum += field.radiance[i][0] * p.area;
        exact_sum += exact * p.area;
        if (exact == 0.0)
            dark = std::max(dark, field.radiance[i][0]);
        else if (exact > 0.2)  // where the light is more than a tenth of its peak
            worst = std::max(worst, std::abs(field.radiance[i][0] / exact - 1.0));
    }
    INFO("worst relative deviation " << worst << ", total " << sum / exact_sum);
    CHECK(worst < 0.01);
    CHECK(sum / exact_sum == Approx(1.0).epsilon(0.002));
    CHECK(dark == 0.0);  // outside the cone: nothing
}

TEST_CASE("a narrow spot whose cone lands inside one patch: its light, within 3 %", "[solver][first-shot]") {
    // A 5-degree spot 0.5 above a plane of two triangles (as modelled): every corner is
    // outside the cone, which lights a disc of radius 0.044 inside one of them.
    const double rho = 0.5;
    auto scene = plane(rho, 10.0);
    REQUIRE(scene.patch_count() == 2);
    scenes::PointLight spot;
    spot.position = Vec3(0.3, 0.2, 0.5);
    spot.intensity = Rgb::Constant(1.0);
    spot.axis = Vec3(0, 0, -1);
    spot.cos_inner = std::cos(3.0 * M_PI / 180.0);
    spot.cos_outer = std::cos(5.0 * M_PI / 180.0);
    scene.point_lights.push_back(spot);
    const solver::FirstShot shot = shoot(scene);
    const auto& pos = scene.vertex_positions();
    double got = 0.0, exact = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        got += shot.irradiance[i][0] * p.area;
        exact += p.area * triangle_mean({pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]}, 9, [&](const Vec3& x) {
                     const Vec3 d = spot.position - x;
                     return spot.falloff(-d.normalized()) * d.z() / d.norm() / d.squaredNorm();
                 });
    }
    INFO("irradiance integral " << got << ", exact " << exact);
    CHECK(got == Approx(exact).epsilon(0.03));
}

TEST_CASE("point light: shadows are exact, and a light behind a patch gives nothing", "[solver][first-shot]") {
    auto scene = plane(0.5, 0.06);
    // An occluder 0.25 x 0.25 at z = 0.25 under a light at z = 1 (facing up, so it
    // sends nothing down): its umbra on the plane is the square |x|, |y| < 1/6.
    add_square(scene, 0.125, 0.25);
    scene.point_lights.push_back({Vec3(0, 0, 1), Rgb::Constant(1.0)});
    scene.point_lights.push_back({Vec3(0, 0, -1), Rgb::Constant(1.0)});  // below the plane: no effect
    const solver::FirstShot shot = shoot(scene);
    const auto& pos = scene.vertex_positions();
    int in_umbra = 0, lit = 0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        if (p.material != 0) continue;
        double reach = 0.0;  // the farthest corner from the axis (max norm)
        for (int k = 0; k < 3; ++k) reach = std::max({reach, std::abs(pos[p.v[k]].x()), std::abs(pos[p.v[k]].y())});
        if (reach < 1.0 / 6.0 - 1e-9) {
            ++in_umbra;
            CHECK(shot.irradiance[i][0] == 0.0);
        } else if (std::abs(p.centroid.x()) > 0.3 || std::abs(p.centroid.y()) > 0.3) {
            ++lit;
            CHECK(shot.irradiance[i][0] > 0.0);
        }
    }
    CHECK(in_umbra > 0);
    CHECK(lit > 0);
}

TEST_CASE("directional light over a plane: radiance = rho E cos / pi on every patch, none from below",
          "[solver][first-shot]") {
    const double rho = 0.6;
    auto scene = plane(rho, 0.25);
    const Vec3 along = Vec3(0.3, 0.2, -1.0).normalized();
    const Rgb irradiance(3.0, 2.0, 1.0);
    scene.directional_lights.push_back({along, irradiance, "sun"});
    scene.directional_lights.push_back({Vec3(0.1, 0, 1).normalized(), Rgb::Constant(5.0), "from below"});  // from below: nothing
    const solver::Transport transport(scene);
    CHECK(transport.shot_stats().directional == 2);
    CHECK(transport.decisions()["first_shot"].get<std::string>().find("2 directional light(s)") != std::string::npos);
    // Unshadowed everywhere: 16 shadow rays per patch, all of them leaving.
    CHECK(transport.shot_stats().shadow_rays >= 16 * static_cast<long>(scene.patch_count()));
    const auto field = iterate(scene, "painter", 20);
    double worst = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i)
        for (int c = 0; c < 3; ++c)
            worst = std::max(worst, std::abs(field.radiance[i][c] / (rho * irradiance[c] * -along.z() / M_PI) - 1.0));
    CHECK(worst < 1e-12);
}

TEST_CASE("directional light: a square's shadow, patch by patch and in all, within 1 %", "[solver][first-shot]") {
    // A square of side 0.5 at z = 0.25 over the plane, the sun travelling along
    // (0.3, 0.2, -1): its shadow is the square moved by (0.075, 0.05), whose edges cross
    // patches of 0.1 at slants.
    auto scene = plane(0.5, 0.1);
    add_square(scene, 0.25, 0.25);
    const Vec3 along = Vec3(0.3, 0.2, -1.0).normalized();
    scene.directional_lights.push_back({along, Rgb::Constant(2.0), "sun"});
    const solver::FirstShot shot = shoot(scene);
    const auto& pos = scene.vertex_positions();
    const double full = 2.0 * -along.z();
    // The shadow's share of a patch, by a fine grid of points over it.
    auto shadowed = [](const Vec3& x) {
        return std::abs(x.x() - 0.075) < 0.25 && std::abs(x.y() - 0.05) < 0.25 ? 1.0 : 0.0;
    };
    double got = 0.0, worst = 0.0;
    int crossed = 0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        if (p.material != 0) continue;
        const double share = 1.0 - triangle_mean({pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]}, 7, shadowed);
        got += shot.irradiance[i][0] * p.area;
        if (share > 0.0 && share < 1.0) ++crossed;
        // (per patch: the error against the patch's full irradiance)
        worst = std::max(worst, std::abs(shot.irradiance[i][0] - full * share) / full);
    }
    INFO("worst patch " << worst << " of its full irradiance, " << crossed << " patches crossed by the shadow's edge");
    CHECK(crossed > 20);
    CHECK(worst < 0.01);  // measured 0.0026 (1,024 points of R2 on a crossed patch)
    CHECK(got == Approx(full * (4.0 - 0.25)).epsilon(0.001));
}

TEST_CASE("directional light: glossy patches keep its direction, and any thread count gives the same shot",
          "[solver][first-shot]") {
    // A glossy plane under a sun, a square casting a shadow across its patches.
    auto scene = plane(0.3, 0.1);
    scene.materials[0].specular = Rgb::Constant(0.5);
    scene.materials[0].exponent = 20.0;
    add_square(scene, 0.25, 0.25);
    const Vec3 along = Vec3(0.3, 0.2, -1.0).normalized();
    scene.directional_lights.push_back({along, Rgb(1.0, 2.0, 3.0), "sun"});
    const scenes::RayCaster caster(scene);
    const solver::FirstShot one = solver::first_shot(scene, caster, 1), three = solver::first_shot(scene, caster, 3);
    CHECK(one.shadow_rays == three.shadow_rays);
    CHECK(std::equal(one.irradiance.begin(), one.irradiance.end(), three.irradiance.begin(),
                     [](const Rgb& a, const Rgb& b) { return (a == b).all(); }));
    REQUIRE(one.glossy_hits.size() == three.glossy_hits.size());
    std::size_t unshadowed = 0;
    for (std::size_t k = 0; k < one.glossy_hits.size(); ++k) {
        const auto& h = one.glossy_hits[k];
        CHECK(h.patch == three.glossy_hits[k].patch);
        CHECK(h.direction == along);  // its direction of travel, as a point light's hit
        CHECK(h.irradiance.isApprox(one.irradiance[h.patch]));
        if (h.irradiance.isApprox(Rgb(1.0, 2.0, 3.0) * -along.z())) ++unshadowed;
    }
    CHECK(unshadowed > scene.patch_count() / 2);
}

TEST_CASE("directional light through a window: the power the room's patches receive is E cos A",
          "[solver][first-shot]") {
    // A closed room 5 x 3 x 4 (as scenes/examples/window.json models it: whole walls,
    // the window wall in four parts around the opening) and a bench on its floor; the
    // sun travels along (0.3, -0.6, -1): everything that enters through the window
    // lands on a front inside. Refined, the patch edges cross the beam's edges at
    // slants; as modelled (no bench then), a small window's pool of sunlight lies
    // inside one of the floor's two triangles, whose first 58^2 points find it.
    struct Case {
        const char* patch_size;
        double x0, x1, y0, y1;  // the window
        bool bench;
    };
    const Case c = GENERATE(Case{"0.25", 1.5, 3.5, 1.0, 2.4, true}, Case{"\"none\"", 2.1, 2.4, 1.6, 1.9, false});
    auto quad = [](double xa, double xb, double ya, double yb) {
        std::ostringstream q;
        q << R"({"quad": [[)" << xa << ", " << ya << ", 4], [" << xa << ", " << yb << ", 4], [" << xb << ", " << yb
          << ", 4], [" << xb << ", " << ya << R"(, 4]], "material": "plaster"},)";
        return q.str();
    };
    std::string objects = R"(
        {"quad": [[0, 0, 0], [0, 0, 4], [5, 0, 4], [5, 0, 0]], "material": "plaster"},
        {"quad": [[0, 3, 0], [5, 3, 0], [5, 3, 4], [0, 3, 4]], "material": "plaster"},
        {"quad": [[0, 0, 0], [5, 0, 0], [5, 3, 0], [0, 3, 0]], "material": "plaster"},
        {"quad": [[0, 0, 0], [0, 3, 0], [0, 3, 4], [0, 0, 4]], "material": "plaster"},
        {"quad": [[5, 0, 0], [5, 0, 4], [5, 3, 4], [5, 3, 0]], "material": "plaster"},)" +
                          quad(0, c.x0, 0, 3) + quad(c.x1, 5, 0, 3) + quad(c.x0, c.x1, 0, c.y0) +
                          quad(c.x0, c.x1, c.y1, 3);
    if (c.bench)
        objects += R"(
        {"quad": [[1.8, 0.45, 1.6], [1.8, 0.45, 2.4], [3.2, 0.45, 2.4], [3.2, 0.45, 1.6]], "material": "plaster"},
        {"quad": [[1.8, 0, 2.4], [3.2, 0, 2.4], [3.2, 0.45, 2.4], [1.8, 0.45, 2.4]], "material": "plaster"},)";
    objects.pop_back();  // the last object's comma
    const std::string room = R"({
      "camera": {"eye": [4.6, 1.6, 0.3], "target": [2.0, 1.0, 3.2]},
      "materials": {"plaster": {"albedo": [0.75, 0.74, 0.72]}},
      "objects": [)" + objects + R"(],
      "patch_size": )" + c.patch_size + R"(,
      "directional_lights": [{"direction": [0.3, -0.6, -1], "irradiance": [1, 1, 1]}]})";
    const scenes::Scene scene = scenes::parse_scene(room, "room.json", ".");
    const solver::FirstShot shot = shoot(scene);
    double power = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) power += shot.irradiance[i][0] * scene.patch_list()[i].area;
    const double exact = (c.x1 - c.x0) * (c.y1 - c.y0) * Vec3(0.3, -0.6, -1).normalized().cwiseAbs().z();
    INFO("patch size " << c.patch_size << ": received " << power << ", through the window " << exact << ", "
                       << scene.patch_count() << " patches");
    CHECK(power == Approx(exact).epsilon(0.005));
}

TEST_CASE("open plane under a uniform sky: radiance = albedo x sky radiance", "[solver][sky]") {
    auto scene = plane(0.5, 0.25);
    scenes::Sky sky;
    sky.radiance = Rgb(1.0, 2.0, 0.5);
    sky.up = Vec3(0, 0, 1);
    scene.sky = sky;
    const auto backend = GENERATE(as<std::string>{}, "painter", "global-zbuffer", "raycast");
    const auto field = iterate(scene, backend, 4000);
    const double mean = field.mean_radiance(scene);
    INFO(backend << ": mean radiance " << mean << ", expected " << 0.5 * sky.radiance.mean());
    // Every patch, every channel within 3 %; the mean (all patches share directions)
    // within 2 %.
    CHECK(mean == Approx(0.5 * sky.radiance.mean()).epsilon(0.02));
    for (std::size_t i = 0; i < scene.patch_count(); ++i)
        for (int c = 0; c < 3; ++c) CHECK(field.radiance[i][c] == Approx(0.5 * sky.radiance[c]).epsilon(0.03));
}

TEST_CASE("CIE overcast sky: an open plane gets 7/9 albedo x zenith radiance", "[solver][sky]") {
    // E = int L_z (1 + 2 cos t) / 3 cos t dw = 7 pi L_z / 9, so L = rho E / pi = 7 rho L_z / 9.
    auto scene = plane(0.5, 0.25);
    scenes::Sky sky;
    sky.radiance = Rgb::Constant(1.0);
    sky.up = Vec3(0, 0, 1);
    sky.model = scenes::Sky::Model::overcast;
    scene.sky = sky;
    const auto field = iterate(scene, "painter", 4000);
    CHECK(field.mean_radiance(scene) == Approx(7.0 * 0.5 / 9.0).epsilon(0.02));
}

TEST_CASE("a closed box under a sky sees none of it", "[solver][sky]") {
    // The sky entries must not leak into a closed scene: the homogeneous box stays at 1.
    auto scene = scenes::Scene();
    {
        // The walls of a unit cube facing inwards, albedo 0.5, emission 0.5.
        scenes::Material m;
        m.name = "wall";
        m.albedo = Rgb::Constant(0.5);
        m.emission = Rgb::Constant(0.5);
        const int mat = scene.add_material(m);
        const std::array<std::array<Vec3, 4>, 6> q = {{
            {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}},
            {{{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}}},
            {{{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}}},
            {{{1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}}},
            {{{0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}}},
            {{{0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}}},
        }};
        for (const auto& f : q) scene.add_object({f[0], f[1], f[2], f[3]}, {{{0, 1, 2}}, {{0, 2, 3}}}, mat);
        scene.finalize();
        scenes::subdivide(scene, 0.34);
    }
    scenes::Sky sky;
    sky.radiance = Rgb::Constant(5.0);
    scene.sky = sky;
    const auto field = iterate(scene, "painter", 2000);
    CHECK(field.mean_radiance(scene) == Approx(1.0).epsilon(0.01));
}

TEST_CASE("walks use the sky and the first shot too", "[solver][sky][walks]") {
    auto scene = plane(0.5, 0.25);
    scenes::Sky sky;
    sky.radiance = Rgb::Constant(1.0);
    sky.up = Vec3(0, 0, 1);
    scene.sky = sky;
    visibility::BackendOptions bo;
    bo.sky = true;
    auto backend = visibility::make_backend("painter", scene, bo);
    const solver::Transport transport(scene);
    solver::SolverOptions opt;
    opt.depth = 2;
    opt.steps = 1000;
    solver::GlobalWalks w(transport, *backend, solver::WalkMethod::bidirectional, opt, {});
    w.run();
    // One bounce is all there is on an open plane: truncation changes nothing.
    CHECK(w.field().mean_radiance(scene) == Approx(0.5).epsilon(0.02));
}

TEST_CASE("diffuse shot: the direct light in a closed box is rho Le sum F = 0.25 everywhere", "[solver][diffuse-shot]") {
    // Le = 0.5, albedo 0.5, closed: E = pi Le sum_j F_ij = pi Le, so rho E / pi = 0.25,
    // including patches next to a shared edge (Lambert's closed form is exact there).
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    long rays = 0;
    std::vector<Rgb> E;
    {
        const scenes::RayCaster caster(scene);
        E = solver::diffuse_shot(scene, caster, rays);
    }
    CHECK(rays > 0);
    double worst = 0.0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) worst = std::max(worst, std::abs(0.5 * E[i][0] / M_PI - 0.25));
    INFO("worst deviation " << worst);
    CHECK(worst < 0.25 * 0.005);
}

namespace {

// A 4 x 4 floor of 8 x 8 cells (two triangles each) facing up, a 1 x 1 lamp at height 2
// facing down (its sides lamp_u and lamp_v: tilted where they are not the axes), of n x n cells (one object, so that its patches form one group when
// there are many), and a 1 x 1 blocker at height 1 over a corner of the lamp's
// footprint: lit, penumbra and umbra on the floor.
scenes::Scene lamp_over_floor(int n, const Vec3& lamp_u = {0, 1, 0}, const Vec3& lamp_v = {1, 0, 0}) {
    scenes::Scene s;
    scenes::Material white, lamp;
    white.name = "white";
    white.albedo = Rgb::Constant(0.5);
    lamp.name = "lamp";
    lamp.emission = Rgb::Constant(1.0);
    const int w = s.add_material(white), l = s.add_material(lamp);
    auto grid = [&](Vec3 origin, Vec3 du, Vec3 dv, int cells, int material) {
        std::vector<Vec3> v;
        std::vector<std::array<int, 3>> t;
        for (int b = 0; b <= cells; ++b)
            for (int a = 0; a <= cells; ++a) v.push_back(origin + (a * du + b * dv) / cells);
        for (int b = 0; b < cells; ++b)
            for (int a = 0; a < cells; ++a) {
                const int k = b * (cells + 1) + a;
                t.push_back({k, k + 1, k + cells + 2});
                t.push_back({k, k + cells + 2, k + cells + 1});
            }
        s.add_object(v, t, material);
    };
    grid({-2, -2, 0}, {4, 0, 0}, {0, 4, 0}, 8, w);                 // faces +z
    grid({-0.5, -0.5, 2}, lamp_u, lamp_v, n, l);                   // faces -z (tilted by lamp_u, lamp_v)
    grid({0.2, 0.2, 1}, {0, 1, 0}, {1, 0, 0}, 1, w);               // blocker, faces -z
    s.finalize();
    s.camera.eye = Vec3(0, -6, 3);
    return s;
}

}  // namespace

TEST_CASE("form factor of a region's outline clipped to the receiver's plane: the triangles clipped one by one",
          "[solver][diffuse-shot]") {
    // A lamp at z = 2 facing -z: a 6 x 6 grid of cells (two triangles each) with a hole
    // of 2 x 2 cells and a corner notch, so that its outline is two loops and a plane
    // can cross it up to six times. From random points below it with random normals,
    // point_to_outline against the sum of Lambert's formula over each triangle's part in
    // front of the point's plane, clipped here on its own.
    std::vector<std::array<Vec3, 3>> tris;
    for (int b = 0; b < 6; ++b)
        for (int a = 0; a < 6; ++a) {
            if ((a == 2 || a == 3) && (b == 2 || b == 3)) continue;  // the hole
            if (a >= 4 && b >= 4) continue;                          // the notch
            auto at = [](int u, int v) { return Vec3(-1.5 + 0.5 * u, -1.5 + 0.5 * v, 2.0); };
            // Clockwise seen from above: the normal (p1 - p0) x (p2 - p0) points down.
            tris.push_back({at(a, b), at(a, b + 1), at(a + 1, b + 1)});
            tris.push_back({at(a, b), at(a + 1, b + 1), at(a + 1, b)});
        }
    // The outline: directed edges without their reverse.
    std::map<std::array<double, 6>, int> edges;
    auto key = [](const Vec3& p, const Vec3& q) { return std::array<double, 6>{p.x(), p.y(), p.z(), q.x(), q.y(), q.z()}; };
    for (const auto& t : tris)
        for (int k = 0; k < 3; ++k) {
            const Vec3 &p = t[k], &q = t[(k + 1) % 3];
            if (auto back = edges.find(key(q, p)); back != edges.end() && back->second > 0) --back->second;
            else ++edges[key(p, q)];
        }
    std::vector<std::array<Vec3, 2>> outline;
    for (const auto& [e, count] : edges)
        for (int k = 0; k < count; ++k) outline.push_back({Vec3(e[0], e[1], e[2]), Vec3(e[3], e[4], e[5])});
    REQUIRE(outline.size() == 4 * 6 + 4 * 2);  // the outer loop's 24 edges (notch included) and the hole's 8

    auto clipped = [](const Vec3& x, const Vec3& n, const std::array<Vec3, 3>& t) {
        std::vector<Vec3> poly;
        for (int k = 0; k < 3; ++k) {
            const Vec3 &p = t[k], &q = t[(k + 1) % 3];
            const double dp = n.dot(p - x), dq = n.dot(q - x);
            if (dp > 0.0) poly.push_back(p);
            if ((dp > 0.0) != (dq > 0.0)) poly.push_back(p + dp / (dp - dq) * (q - p));
        }
        double F = 0.0;
        for (std::size_t k = 2; k < poly.size(); ++k) F += solver::point_to_triangle(x, n, {poly[0], poly[k - 1], poly[k]});
        return F;
    };
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    int partly = 0, wholly = 0, none = 0;
    double worst = 0.0;
    for (int trial = 0; trial < 4000; ++trial) {
        const Vec3 x(2.0 * uniform(rng), 2.0 * uniform(rng), 1.05 + 0.9 * uniform(rng));
        Vec3 n(uniform(rng), uniform(rng), uniform(rng));
        if (n.norm() < 0.1) continue;
        n.normalize();
        double by_triangle = 0.0, whole = 0.0;
        for (const auto& t : tris) {
            by_triangle += clipped(x, n, t);
            whole += solver::point_to_triangle(x, n, t);
        }
        const double by_outline = solver::point_to_outline(x, n, outline);
        worst = std::max(worst, std::abs(by_outline - by_triangle));
        if (by_triangle == 0.0) ++none;
        else if (std::abs(by_triangle - whole) < 1e-12) ++wholly;
        else ++partly;
    }
    INFO("partly in front " << partly << ", wholly " << wholly << ", not at all " << none << "; worst difference " << worst);
    CHECK(partly > 1000);
    CHECK(wholly > 100);
    CHECK(none > 100);
    CHECK(worst < 1e-12);
}

TEST_CASE("diffuse shot: a light of many patches shares its shadow rays and keeps the answer", "[solver][diffuse-shot]") {
    // The lamp as 2 patches (each its own emitter) and as 2 * 12^2 = 288 (one group):
    // the floor's irradiance agrees where the lamp is wholly seen (Lambert's closed form
    // over the members or over the group's outline, exact both at each receiver point;
    // the points differ, the group placing more of them as it is nearer: 1 %), within
    // the quadratures in the shadow, and the group's shot is the same on any number of
    // threads.
    const auto coarse = lamp_over_floor(1), fine = lamp_over_floor(12);
    const std::size_t floor_patches = 2 * 8 * 8;
    long rays_coarse = 0, rays_fine = 0, rays_three = 0;
    std::vector<Rgb> a, b, c;
    {
        const scenes::RayCaster caster(coarse);
        a = solver::diffuse_shot(coarse, caster, rays_coarse);
    }
    {
        const scenes::RayCaster caster(fine);
        std::size_t groups = 0;
        b = solver::diffuse_shot(fine, caster, rays_fine, {}, &groups);
        CHECK(groups == 1);  // the lamp's 288 patches share their rays
        sampling::RunOptions three;
        three.threads = 3;
        c = solver::diffuse_shot(fine, caster, rays_three, three);
    }
    CHECK(rays_three == rays_fine);
    double sum_a = 0.0, sum_b = 0.0, worst_lit = 0.0;
    int lit = 0, shaded = 0;
    for (std::size_t i = 0; i < floor_patches; ++i) {
        REQUIRE(b[i][0] == c[i][0]);
        const auto& p = coarse.patch_list()[i];
        sum_a += p.area * a[i][0];
        sum_b += p.area * b[i][0];
        // Wholly lit: no line from the patch to the lamp passes the blocker (its
        // shadow on the floor lies within x, y > 0.2 - 0.7 = -0.5).
        bool clear = true;
        for (int k = 0; k < 3; ++k) {
            const Vec3& v = coarse.vertex_positions()[p.v[k]];
            clear = clear && (v.x() < -0.5 || v.y() < -0.5);
        }
        if (clear) {
            ++lit;
            worst_lit = std::max(worst_lit, std::abs(b[i][0] / a[i][0] - 1.0));
        } else if (a[i][0] < 0.9 * b[i][0] || b[i][0] < 0.9 * a[i][0]) {
            ++shaded;  // patches whose two quadratures differ by over 10 %
        }
    }
    INFO("wholly lit patches: " << lit << ", worst relative difference " << worst_lit
                                << "; shadowed patches differing by over 10 %: " << shaded);
    CHECK(lit > 40);
    CHECK(worst_lit < 0.01);
    CHECK(sum_b == Approx(sum_a).epsilon(0.01));
    CHECK(shaded <= 4);
}

TEST_CASE("diffuse shot: the same solution, less noise", "[solver][diffuse-shot]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    auto run = [&](bool shot, std::uint64_t seed) {
        const solver::Transport transport(scene, solver::ShotOptions{shot});
        auto backend = visibility::make_backend("painter", scene, {});
        solver::SolverOptions opt;
        sampling::RunOptions opt_run;
        opt.steps = 1000;
        opt_run.seed = seed;
        solver::StochasticIteration it(transport, *backend, opt, opt_run);
        it.run();
        return it.field();
    };
    double with = 0.0, without = 0.0;
    for (int k = 0; k < 4; ++k) {
        const auto a = run(true, 1 + k), b = run(false, 1 + k);
        CHECK(a.mean_radiance(scene) == Approx(1.0).epsilon(0.01));
        with += a.relative_l1_error(scene, 1.0);
        without += b.relative_l1_error(scene, 1.0);
    }
    INFO("mean error over 4 seeds: with the diffuse shot " << with / 4 << ", without " << without / 4);
    CHECK(with < 0.75 * without);
    // Glossy scenes are refused.
    auto glossy = testing::glossy_box(0.34);
    CHECK_THROWS_WITH(solver::Transport(glossy, solver::ShotOptions{true}), Catch::Contains("diffuse scenes only"));
}

TEST_CASE("glossy scenes keep the first shot of diffuse patches that face away from the eye", "[solver][first-shot]") {
    // A glossy panel faces the camera, a diffuse one faces away, lit by a point light
    // on its side: its radiance (direction-independent) must not drop to zero.
    scenes::Scene s;
    scenes::Material glossy, matte;
    glossy.name = "glossy";
    glossy.albedo = Rgb::Constant(0.3);
    glossy.specular = Rgb::Constant(0.3);
    glossy.exponent = 20;
    matte.name = "matte";
    matte.albedo = Rgb::Constant(0.5);
    const int g = s.add_material(glossy), d = s.add_material(matte);
    s.add_object({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, g);    // faces +z
    s.add_object({{-1, -1, -1}, {-1, 1, -1}, {1, 1, -1}, {1, -1, -1}}, {{{0, 1, 2}}, {{0, 2, 3}}}, d);  // faces -z
    s.finalize();
    s.camera.eye = Vec3(0, 0, 5);
    s.point_lights.push_back({Vec3(0, 0, -2), Rgb::Constant(1.0)});
    const solver::Transport t(s);
    const auto field = t.field_from(std::vector<Rgb>(s.patch_count(), Rgb::Zero()), 1, t.directions_to_eye());
    for (std::size_t i = 0; i < s.patch_count(); ++i)
        if (s.patch_list()[i].material == d) CHECK(field.radiance[i][0] > 0.0);
}

TEST_CASE("diffuse shot and area lights: a tilted light's own points get none of its light", "[solver][diffuse-shot]") {
    // A lamp of 2 x 12^2 patches (one group) in a plane of no axis, over a floor: its
    // points lie on its plane up to rounding, on either side of it. Neither the shot's
    // group sum nor the final gather's area light may give them any of its light (with
    // only the sign of the distance tested, they got 7e-17 here; a point inside the
    // outline can get a form factor of 1, the clipping's closing angles wrapping).
    const auto s = lamp_over_floor(12, {0.1, 1, 0.3}, {1, 0.13, -0.2});
    const std::size_t floor_patches = 2 * 8 * 8;
    long rays = 0;
    std::vector<Rgb> E;
    {
        const scenes::RayCaster caster(s);
        std::size_t groups = 0;
        E = solver::diffuse_shot(s, caster, rays, {}, &groups);
        REQUIRE(groups == 1);
    }
    int lit_floor = 0;
    for (std::size_t i = 0; i < floor_patches; ++i) lit_floor += E[i][0] > 0.0;
    CHECK(lit_floor > 100);
    const std::size_t lamp_end = floor_patches + 2 * 12 * 12;  // then the blocker
    for (std::size_t i = floor_patches; i < lamp_end; ++i) REQUIRE(s.material_of(i).emissive());
    double worst = 0.0;
    for (std::size_t i = floor_patches; i < lamp_end; ++i) worst = std::max(worst, E[i][0]);
    INFO("worst " << std::scientific << worst);
    CHECK(worst == 0.0);

    const render::AreaLights lights(s);
    const auto& pos = s.vertex_positions();
    double worst_point = 0.0;
    for (std::size_t i = floor_patches; i < lamp_end; ++i) {
        const auto& p = s.patch_list()[i];
        for (const auto& [u, v] : {std::pair{0.2, 0.3}, std::pair{0.6, 0.1}, std::pair{1.0 / 3, 1.0 / 3}}) {
            const Vec3 x = (1 - u - v) * pos[p.v[0]] + u * pos[p.v[1]] + v * pos[p.v[2]];
            worst_point = std::max(worst_point, lights.irradiance(x, p.normal)[0]);
        }
    }
    INFO("worst point " << std::scientific << worst_point);
    CHECK(worst_point == 0.0);
}
