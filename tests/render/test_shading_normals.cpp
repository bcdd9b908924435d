// Shading normals in the renderer: the G-buffer's shading normal next to the patch
// normal, and the smooth patch image averaging corners that share a shading normal.
#include "gather_options.h"
#include "render/camera.h"
#include "render/final_gather.h"
#include "render/gbuffer.h"
#include "render/path_tracer.h"
#include "render/shade.h"
#include "scenes/ray_caster.h"
#include "tests/scenes/uv_sphere.h"

#include <catch2/catch.hpp>

#include <cmath>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;
using test::degrees_between;

TEST_CASE("the G-buffer carries the interpolated shading normal next to the patch normal", "[render][normals]") {
    const auto sphere = test::uv_sphere(24, 12);
    scenes::Scene scene;
    const int white = scene.add_material({"white", Rgb::Constant(0.5)});
    scene.add_object(sphere.vertices, sphere.triangles, white, "sphere");
    scene.finalize();
    scene.camera.eye = Vec3(0.3, -0.2, 4);
    scene.camera.target = Vec3::Zero();
    scene.camera.fov_y = 35;
    scene.camera.width = scene.camera.height = 64;
    const scenes::RayCaster caster(scene);
    const render::GBuffer g = render::make_gbuffer(scene, caster, render::PinholeCamera(scene.camera));

    int hits = 0;
    double shading = 0.0, geometric = 0.0;
    const auto& pos = scene.vertex_positions();
    for (const auto& s : g.samples) {
        if (s.patch < 0) continue;
        ++hits;
        const auto& p = scene.patch_list()[s.patch];
        REQUIRE(s.front);
        // b1, b2 weigh the patch's 2nd and 3rd vertex, as Scene::shading_normal reads them.
        const Vec3 x = (1 - s.b1 - s.b2) * pos[p.v[0]] + s.b1 * pos[p.v[1]] + s.b2 * pos[p.v[2]];
        REQUIRE((x - s.point).norm() < 1e-5);
        shading = std::max(shading, degrees_between(scene.shading_normal(s.patch, s.b1, s.b2), s.point.normalized()));
        geometric = std::max(geometric, degrees_between(p.normal, s.point.normalized()));
    }
    // Measured over 2,107 hits: shading normals 0.60 degrees from the sphere's at most,
    // patch normals 9.5.
    CHECK(hits > 1000);
    CHECK(geometric > 5.0);
    CHECK(shading < 1.0);
}

TEST_CASE("the smooth patch image averages corners that share a shading normal", "[render][normals]") {
    // Two triangles folded by 20 degrees along the edge (0,0,0)-(1,0,0).
    const double fold = 20.0 * M_PI / 180.0;
    const std::vector<Vec3> v = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -std::cos(fold), std::sin(fold)}};
    const std::vector<std::array<int, 3>> t = {{0, 1, 2}, {1, 0, 3}};
    solver::RadianceField field;
    field.radiance = {Rgb::Constant(1.0), Rgb::Constant(3.0)};

    auto corner_at_origin = [&](const scenes::Scene& scene) {
        const auto corners = render::corner_radiance(scene, field);
        REQUIRE(scene.patch_count() == 2);
        for (int k = 0; k < 3; ++k)
            if (scene.vertex_positions()[scene.patch_list()[0].v[k]] == Vec3::Zero()) return corners[0][k][0];
        FAIL("no corner at the origin");
        return 0.0;
    };
    auto make = [&](double crease, const std::vector<std::array<Vec3, 3>>& normals) {
        scenes::Scene scene;
        const int white = scene.add_material({"white", Rgb::Constant(0.5)});
        const int id = scene.add_object(v, t, white, "fold", -1, normals);
        scene.crease_angles[id] = crease;
        scene.finalize();
        return scene;
    };
    // Computed with the default 30 degree crease: one smooth surface, equal areas.
    CHECK(corner_at_origin(make(30.0, {})) == Approx(2.0));
    // Crease angle 10: two flat faces, each keeps its own radiance.
    CHECK(corner_at_origin(make(10.0, {})) == Approx(1.0));
    // The file's normals decide: each face its own normal (a hard edge) ...
    const Vec3 n0(0, 0, 1), n1 = (v[0] - v[1]).cross(v[3] - v[1]).normalized();
    CHECK(corner_at_origin(make(30.0, {{n0, n0, n0}, {n1, n1, n1}})) == Approx(1.0));
    // ... or one normal shared by both at every vertex (smooth).
    const Vec3 m = (n0 + n1).normalized();
    CHECK(corner_at_origin(make(30.0, {{m, m, n0}, {m, m, n1}})) == Approx(2.0));
}

TEST_CASE("final gather and path tracer: a coarse sphere shades like a fine one", "[render][normals][gather]") {
    // A sphere under a point light (no area lights, no interreflection): the image of a
    // 16 x 8 tessellation with shading normals against that of a 96 x 48 one. With flat
    // normals (crease angle 0) the facets show.
    auto image = [](int segments, int rings, double crease, bool path_trace) {
        const auto sphere = test::uv_sphere(segments, rings);
        scenes::Scene scene;
        const int white = scene.add_material({"white", Rgb::Constant(0.7)});
        const int object = scene.add_object(sphere.vertices, sphere.triangles, white, "sphere");
        scene.crease_angles[static_cast<std::size_t>(object)] = crease;
        scene.finalize();
        scene.point_lights.push_back({Vec3(3, 2, 4), Rgb::Constant(20.0)});
        scene.camera.eye = Vec3(0, 0, 4);
        scene.camera.target = Vec3::Zero();
        scene.camera.fov_y = 35;
        scene.camera.width = scene.camera.height = 48;
        const scenes::RayCaster caster(scene);
        const render::PinholeCamera camera(scene.camera);
        if (path_trace) {
            render::PathTraceOptions po;
            po.spp = 16;
            return render::path_trace(scene, caster, camera, po, {}).image;
        }
        solver::RadianceField field;
        field.radiance.assign(scene.patch_count(), Rgb::Zero());
        render::GatherOptions o = guide_only_gather();
        o.gather_rays = 1;
        o.spp = 16;
        return render::final_gather(scene, caster, field, camera, o, {}).image;
    };
    // Relative L1 inside the central disc of 0.8 times the sphere's projected radius
    // (about 19.6 pixels), away from the silhouettes, which differ by tessellation.
    auto l1 = [](const render::Image& a, const render::Image& ref) {
        double diff = 0.0, sum = 0.0;
        for (int y = 0; y < ref.height; ++y)
            for (int x = 0; x < ref.width; ++x) {
                if (std::hypot(x + 0.5 - 24.0, y + 0.5 - 24.0) > 0.8 * 19.6) continue;
                for (int k = 0; k < 3; ++k) {
                    diff += std::abs(a.at(x, y)[k] - ref.at(x, y)[k]);
                    sum += std::abs(ref.at(x, y)[k]);
                }
            }
        return diff / sum;
    };
    for (const bool path_trace : {false, true}) {
        const auto fine = image(96, 48, 30.0, path_trace);
        const double smooth = l1(image(16, 8, 30.0, path_trace), fine);
        const double flat = l1(image(16, 8, 0.0, path_trace), fine);
        INFO((path_trace ? "path tracer" : "final gather") << ": relative L1 against the fine sphere, shading normals "
                                                            << smooth << ", flat " << flat);
        CHECK(smooth < 0.05);
        CHECK(flat > 2.5 * smooth);  // measured 0.022 and 0.076 (gather), 0.023 and 0.076 (path tracer)
    }
}
