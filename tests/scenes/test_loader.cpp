// Scene loading: a valid scene, and every bad-input case ending in one clear
// SceneError that names the file, the object and the value.
#include "scenes/builtin.h"
#include "scenes/diagnostics.h"
#include "scenes/loader.h"
#include "scenes/errors.h"

#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace raybundle::scenes;
using Catch::Matchers::Contains;

using raybundle::test::TempDir;

namespace {

const char* kCamera = R"("camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "width": 64, "height": 48})";
const char* kMaterials = R"("materials": {"white": {"albedo": [0.5, 0.5, 0.5]}, "lamp": {"albedo": [0.1, 0.1, 0.1], "emission": [2, 2, 2]}})";
const char* kQuad = R"({"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "white"})";

// The patches as modelled unless `extra` gives a patch size.
std::string scene_text(const std::string& camera, const std::string& materials, const std::string& objects,
                       const std::string& extra = "") {
    const std::string size = extra.find("\"patch_size\"") == std::string::npos ? ", \"patch_size\": \"none\"" : "";
    return "{" + camera + ", " + materials + ", \"objects\": [" + objects + "]" + extra + size + "}";
}

Scene parse(const std::string& text, const std::string& dir = ".") { return parse_scene(text, "s.json", dir); }

}  // namespace

TEST_CASE("a valid scene loads with its camera, materials and patches", "[scenes]") {
    const Scene s = parse(scene_text(kCamera, kMaterials, kQuad, R"(, "patch_size": 0.25)"));
    CHECK(s.camera.width == 64);
    CHECK(s.camera.height == 48);
    CHECK(s.camera.fov_y == 45.0);
    CHECK(s.materials.size() == 2);
    CHECK(s.patch_count() > 2);
    CHECK(s.total_area() == Approx(1.0).epsilon(1e-12));
    for (const auto& p : s.patch_list()) CHECK(p.normal.z() == Approx(1.0));  // counter-clockwise front
}

TEST_CASE("without a patch size a scene is refined to 1/25 of its largest extent, and \"none\" keeps it as modelled",
          "[scenes]") {
    // A 4 x 1 floor and a unit quad above it: the largest extent is 4, so no edge is
    // left longer than 0.16.
    const std::string objects = R"({"quad": [[0,0,0], [4,0,0], [4,1,0], [0,1,0]], "material": "white"},
                                   {"quad": [[0,0,1], [1,0,1], [1,1,1], [0,1,1]], "material": "lamp"})";
    auto longest_edge = [](const Scene& s) {
        double longest = 0.0;
        const auto& pos = s.vertex_positions();
        for (const auto& p : s.patch_list())
            for (int k = 0; k < 3; ++k) longest = std::max(longest, (pos[p.v[k]] - pos[p.v[(k + 1) % 3]]).norm());
        return longest;
    };
    const std::string doc = "{" + std::string(kCamera) + ", " + kMaterials + R"(, "objects": [)" + objects + "]}";
    const Scene automatic = parse(doc);
    CHECK(longest_edge(automatic) <= 0.16 + 1e-12);
    CHECK(longest_edge(automatic) > 0.08);  // no finer than it needs
    CHECK(automatic.total_area() == Approx(5.0).epsilon(1e-12));
    CHECK_THAT(automatic.refinement, Contains("patch size 0.16") && Contains("automatic") && Contains("extent, 4"));
    const Scene named = parse(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": "auto")"));
    CHECK(named.patch_count() == automatic.patch_count());
    const Scene modelled = parse(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": "none")"));
    CHECK(modelled.patch_count() == 4);
    CHECK_THAT(modelled.refinement, Contains("none"));
    const Scene given = parse(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": 0.5)"));
    CHECK(longest_edge(given) <= 0.5 + 1e-12);
    CHECK(given.patch_count() < automatic.patch_count());
    CHECK_THAT(given.refinement, Contains("patch size 0.5 (the scene's)"));
    CHECK_THROWS_WITH(parse(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": "fine")")),
                      Contains("s.json") && Contains("patch_size") && Contains(R"(expected a number, "auto" or "none", got "fine")"));
    CHECK_THROWS_WITH(parse(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": true)")),
                      Contains("patch_size: expected a number, got"));
    // Where the automatic size would pass the patch limit, the error says so.
    LoadLimits few;
    few.max_patches = 500;
    CHECK_THROWS_WITH(parse_scene(doc, "s.json", ".", {}, few),
                      Contains("s.json: patch_size: the automatic size (1/25 of the largest extent) 0.16 would make about") &&
                          Contains("(limit 500): set \"patch_size\" to a larger number or \"none\""));
    // The estimate is a lower bound; where it lets a size through that makes more, the
    // refinement stops at the pass that would pass the limit, with the count it makes.
    LoadLimits exact;
    exact.max_patches = static_cast<double>(automatic.patch_count()) - 1.0;
    CHECK_THROWS_WITH(parse_scene(doc, "s.json", ".", {}, exact),
                      Contains("s.json: patch_size: the automatic size (1/25 of the largest extent) 0.16 makes ") &&
                          Contains(" patches or more (limit "));
    exact.max_patches += 1.0;
    CHECK(parse_scene(doc, "s.json", ".", {}, exact).patch_count() == automatic.patch_count());
    // A machine whose memory holds fewer patches than the limit while the scene is
    // prepared lowers it, and says why.
    LoadLimits small;
    small.memory = {100 * 1200, 100 * 1200, 1, ""};  // 100 patches' preparation
    CHECK_THROWS_WITH(parse_scene(scene_text(kCamera, kMaterials, objects, R"(, "patch_size": 0.25)"), "s.json", ".", {}, small),
                      Contains("s.json: patch_size: 0.25 would make about 320 patches (limit 100: about 1.2 KB each while "
                               "the scene is prepared, and this machine has 120 KB)"));
    // The built-in scenes say theirs.
    CHECK_THAT(load_builtin("homogeneous-box").refinement, Contains("patch size 0.2 (the built-in scene's default)"));
    CHECK_THAT(load_builtin("homogeneous-box", {{"patch_size", "0.5"}}).refinement, Contains("patch size 0.5 (given)"));
}

TEST_CASE("one side of the image given: the other follows the camera's aspect", "[scenes]") {
    const std::string doc = R"({"camera": {"eye": [0, 0, 3], "target": [0, 0, 0], "width": 512, "height": 384},
        "materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}},
        "objects": [{"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "w"}], "patch_size": "none"})";
    const auto sides = [&](const Overrides& o) {
        const Camera c = parse_scene(doc, "s.json", ".", o).camera;
        return std::pair{c.width, c.height};
    };
    CHECK(sides({}) == std::pair{512, 384});
    CHECK(sides({{"camera.width", "64"}}) == std::pair{64, 48});
    CHECK(sides({{"camera.height", "96"}}) == std::pair{128, 96});
    CHECK(sides({{"camera.width", "64"}, {"camera.height", "64"}}) == std::pair{64, 64});  // both: both hold
    CHECK(sides({{"camera.width", "1"}}) == std::pair{1, 1});                                // at least 1
    CHECK(sides({{"camera.width", "16384"}, {"camera.fov_y", "30"}}) == std::pair{16384, 12288});
    CHECK_THROWS_WITH(sides({{"camera.height", "16384"}}),
                      Contains("camera.height: height 16384 makes the width 21845 at the camera's aspect, past 16384: "
                               "give both sides"));
    // The aspect of the camera as the other settings made it, whatever their order.
    const std::string hd = R"({"eye": [0, 0, 3], "target": [0, 0, 0], "width": 1920, "height": 1080})";
    CHECK(sides({{"camera", hd}, {"camera.width", "960"}}) == std::pair{960, 540});
    CHECK(sides({{"camera.width", "960"}, {"camera", hd}}) == std::pair{960, 540});
    // A camera without sides is 512 x 512; a built-in scene's as its camera is.
    CHECK(parse_scene(R"({"camera": {"eye": [0, 0, 3], "target": [0, 0, 0]},
        "materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}},
        "objects": [{"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "w"}]})", "s.json", ".",
                      {{"camera.width", "64"}}).camera.height == 64);
    const Camera box = load_builtin("cornell-box", {{"camera.height", "100"}}).camera;
    CHECK(box.width == 100);
    CHECK(box.height == 100);
}

TEST_CASE("point lights and the sky load", "[scenes]") {
    const Scene s = parse(scene_text(kCamera, kMaterials, kQuad,
                                     R"(, "point_lights": [{"position": [0, 0, 2], "intensity": [10, 5, 1]}],
                                         "sky": {"radiance": [1, 1, 2], "up": [0, 0, 3], "model": "overcast"})"));
    REQUIRE(s.point_lights.size() == 1);
    CHECK(s.point_lights[0].position.z() == 2.0);
    CHECK(s.point_lights[0].intensity[1] == 5.0);
    REQUIRE(s.sky);
    CHECK(s.sky->up.z() == Approx(1.0));  // normalised
    CHECK(s.sky->model == Sky::Model::overcast);
    // Travelling down (from the zenith): the zenith radiance; up: black.
    CHECK(s.sky->arriving_along(Vec3(0, 0, -1))[2] == Approx(2.0));
    CHECK((s.sky->arriving_along(Vec3(0, 0, 1)) == 0.0).all());
    const Scene plain = parse(scene_text(kCamera, kMaterials, kQuad));
    CHECK(plain.point_lights.empty());
    CHECK(!plain.sky);
    // A spot: its direction, its cones in degrees (outer 45 and inner 0 unless given).
    const Scene spot = parse(scene_text(kCamera, kMaterials, kQuad,
                                        R"(, "point_lights": [{"position": [0, 0, 2], "intensity": [1, 1, 1],
                                               "direction": [0, 0, -2], "inner_angle": 10, "outer_angle": 30},
                                              {"position": [0, 0, 2], "intensity": [1, 1, 1], "direction": [1, 0, 0]}])"));
    REQUIRE(spot.point_lights.size() == 2);
    CHECK(spot.point_lights[0].axis.isApprox(Vec3(0, 0, -1)));
    CHECK(spot.point_lights[0].cos_inner == Approx(std::cos(10 * M_PI / 180)));
    CHECK(spot.point_lights[0].cos_outer == Approx(std::cos(30 * M_PI / 180)));
    CHECK(spot.point_lights[1].cos_inner == 1.0);
    CHECK(spot.point_lights[1].cos_outer == Approx(std::sqrt(0.5)));
    const auto light = [&](const std::string& keys) {
        return parse(scene_text(kCamera, kMaterials, kQuad,
                                R"(, "point_lights": [{"position": [0, 0, 2], "intensity": [1, 1, 1], )" + keys + "}]"));
    };
    CHECK_THROWS_WITH(light(R"("outer_angle": 30)"), Contains("point_lights[0].outer_angle: a cone needs the spot's \"direction\""));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, 0])"), Contains("point_lights[0].direction: must be a direction, not [0, 0, 0]"));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, -1], "outer_angle": 0)"),
                      Contains("point_lights[0].outer_angle: must be in (0, 180] degrees, got 0"));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, -1], "outer_angle": 20, "inner_angle": 25)"),
                      Contains("point_lights[0].inner_angle: must be in [0, outer_angle = 20] degrees, got 25"));
}

TEST_CASE("directional lights load: a direction of travel, made unit, and an irradiance", "[scenes]") {
    const Scene s = parse(scene_text(kCamera, kMaterials, kQuad,
                                     R"(, "directional_lights": [{"direction": [0, 0, -2], "irradiance": [3, 2, 1]},
                                                                 {"direction": [1, 1, -1], "irradiance": [0, 0, 0]}])"));
    REQUIRE(s.directional_lights.size() == 2);
    CHECK(s.directional_lights[0].direction.isApprox(Vec3(0, 0, -1)));
    CHECK(s.directional_lights[0].irradiance.isApprox(Rgb(3, 2, 1)));
    CHECK(s.directional_lights[1].direction.norm() == Approx(1.0));
    CHECK(s.has_punctual_lights());
    CHECK_FALSE(parse(scene_text(kCamera, kMaterials, kQuad)).has_punctual_lights());
    const auto light = [&](const std::string& keys) {
        return parse(scene_text(kCamera, kMaterials, kQuad, R"(, "directional_lights": [{)" + keys + "}]"));
    };
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, 0], "irradiance": [1, 1, 1])"),
                      Contains("directional_lights[0].direction: must be a direction, not [0, 0, 0]"));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, -1], "irradiance": [1, -1, 1])"),
                      Contains("directional_lights[0].irradiance: negative irradiance [1, -1, 1]"));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, -1])"), Contains("directional_lights[0].irradiance: missing"));
    CHECK_THROWS_WITH(light(R"("direction": [0, 0, -1], "irradiance": [1, 1, 1], "angle": 0.5)"),
                      Contains("directional_lights[0]: unknown key 'angle' (known: direction, irradiance)"));
    CHECK_THROWS_WITH(parse(scene_text(kCamera, kMaterials, kQuad, R"(, "directional_lights": {"direction": [0, 0, -1]})")),
                      Contains("directional_lights: expected an array, got object"));
    // Named by its key for messages; a direction too short for its norm is one all the same.
    CHECK(s.directional_lights[1].name == "directional_lights[1]");
    CHECK(light(R"("direction": [1e-200, 0, -1e-200], "irradiance": [1, 1, 1])").directional_lights[0].direction.isApprox(
        Vec3(1, 0, -1).normalized()));
}

TEST_CASE("meshes load with polygons triangulated", "[scenes]") {
    TempDir dir;
    dir.write("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    dir.write("tri.off", "OFF\n3 1 0\n0 0 1\n1 0 1\n0 1 1\n3 0 1 2\n");
    const Scene s = parse(scene_text(kCamera, kMaterials,
                                     R"({"mesh": "quad.obj", "material": "white"}, {"mesh": "tri.off", "material": "lamp"})"),
                          dir.path.string());
    CHECK(s.patch_count() == 3);
    CHECK(s.total_area() == Approx(1.5));
}

TEST_CASE("a triangle with a corner given twice is dropped as zero-area in every reader, also as a mesh's first",
          "[scenes]") {
    // OpenMesh cannot make such a face (it asserted where the corner was on no face yet).
    TempDir dir;
    dir.write("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 4 4 3\nf 1 2 3\nf 2 4 3\nf 1 1 1\n");
    dir.write("t.off", "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 3 3 2\n3 0 1 2\n3 1 3 2\n");
    dir.write("t.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                       "element face 3\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 3 3 2\n3 0 1 2\n3 1 3 2\n");
    for (const std::string file : {"t.obj", "t.off", "t.ply"}) {
        INFO(file);
        const Scene s = parse(scene_text(kCamera, kMaterials,
                                         R"({"mesh": ")" + file + R"(", "material": "white", "name": "plate"})"),
                              dir.path.string());
        CHECK(s.patch_count() == 2);
        CHECK(s.total_area() == Approx(1.0));
        CHECK(s.dropped_degenerate == (file == "t.obj" ? 2u : 1u));
        CHECK(s.dropped_summary() == (file == "t.obj" ? "dropped 2 zero-area triangles (plate 2)"
                                                      : "dropped 1 zero-area triangle (plate 1)"));
    }
    // Two-sided: the triangle and its twin go together, counted once (a corner given
    // twice, and three corners on a line).
    dir.write("line.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\n");
    const Scene both = parse_scene(R"({"camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "materials": {"paper": {"albedo": [0.5, 0.5, 0.5], "two_sided": true}},
        "objects": [{"mesh": "line.obj", "material": "paper", "name": "sheet"}], "patch_size": "none"})",
                                   "s.json", dir.path.string());
    CHECK(both.patch_count() == 2);
    CHECK(both.dropped_summary() == "dropped 2 zero-area triangles (sheet 2)");
    // A vertex only a dropped triangle used is gone with it: it bounds nothing.
    dir.write("far.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 100 100 100\nf 1 2 3\nf 4 4 1\nf 1 2 4\n");
    const Scene far = parse(scene_text(kCamera, kMaterials, R"({"mesh": "far.obj", "material": "white"})"),
                            dir.path.string());
    CHECK(far.patch_count() == 2);
    CHECK(far.bounds_radius() > 50.0);  // the fourth vertex is used by the third triangle
    dir.write("far2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 100 100 100\nf 1 2 3\nf 4 4 1\n");
    const Scene near = parse(scene_text(kCamera, kMaterials, R"({"mesh": "far2.obj", "material": "white"})"),
                             dir.path.string());
    CHECK(near.vertex_positions().size() == 3);
    CHECK(near.bounds_radius() < 1.0);
}

TEST_CASE("a mesh's vertices at one place are welded: its triangles share their edges", "[scenes]") {
    // A bent quad as a flat-shaded exporter writes it: a vertex per corner of each
    // triangle. Welded, the two triangles share their diagonal, so the computed normal
    // at its ends is their mean (smooth: the bend is below the crease angle).
    TempDir dir;
    dir.write("split.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.2\nv 0 0 0\nv 1 1 0.2\nv 0 1 0\nf 1 2 3\nf 4 5 6\n");
    const Scene s = parse(scene_text(kCamera, kMaterials, R"({"mesh": "split.obj", "material": "white"})"),
                          dir.path.string());
    CHECK(s.welded_vertices == 2);
    // A sheet exported as its front and its back, each with vertices of its own: the
    // back kept apart from the front, as before welding, without a warning.
    dir.write("sheet.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                           "f 1 2 3\nf 1 3 4\nf 5 7 6\nf 5 8 7\n");
    const Scene sheet = parse(scene_text(kCamera, kMaterials, R"({"mesh": "sheet.obj", "material": "white"})"),
                              dir.path.string());
    CHECK(sheet.welded_vertices == 4);
    CHECK(sheet.patch_count() == 4);
    CHECK(sheet.warnings.empty());
    REQUIRE(s.patch_count() == 2);
    const auto& a = s.patch_list()[0];
    const auto& b = s.patch_list()[1];
    int shared = 0;
    for (int i : a.v)
        for (int j : b.v) shared += i == j;
    CHECK(shared == 2);
    const Vec3 mean = (a.normal + b.normal).normalized();
    for (int k = 0; k < 3; ++k)
        if (a.v[k] == b.v[0] || a.v[k] == b.v[1] || a.v[k] == b.v[2])
            CHECK((s.corner_normals()[0][k] - mean).norm() < 1e-9);
}

TEST_CASE("triangles OpenMesh cannot join are kept apart, and the warning says why", "[scenes]") {
    TempDir dir;
    const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0.5 0.5 1\nv -1 0 0\nv -1 -1 0\n";
    auto warnings_of = [&](const std::string& faces) {
        dir.write("m.obj", v + faces);
        const Scene s = parse(scene_text(kCamera, kMaterials, R"({"mesh": "m.obj", "material": "white", "name": "m"})"),
                              dir.path.string());
        return s.warnings;
    };
    // A neighbour wound the wrong way round: both run the edge 1 -> 2.
    CHECK(warnings_of("f 1 2 3\nf 1 2 4\n") ==
          std::vector<std::string>{"m: 1 triangle with an edge a neighbour runs the same way (one of them wound the "
                                   "wrong way round?): kept as separate triangles, their edges not shared"});
    // A third triangle on an edge two share.
    CHECK(warnings_of("f 1 2 3\nf 2 1 4\nf 1 2 5\n") ==
          std::vector<std::string>{"m: 1 triangle on edges two others already share (non-manifold): kept as "
                                   "separate triangles"});
    // A triangle at a corner whose fan is closed (the apex of a pyramid's four sides).
    CHECK(warnings_of("f 5 1 2\nf 5 2 3\nf 5 3 6\nf 5 6 1\nf 5 7 4\n") ==
          std::vector<std::string>{"m: 1 triangle at corners whose triangles already close around them "
                                   "(non-manifold): kept as separate triangles"});
    CHECK(warnings_of("f 1 2 3\nf 2 1 4\n").empty());
}

TEST_CASE("a mesh object is placed by scale, rotate and translate, a mirror keeping its front", "[scenes]") {
    TempDir dir;
    // A right triangle in centimetres facing +z, with a file normal at each corner.
    dir.write("cm.obj", "v 0 0 0\nv 100 0 0\nv 0 50 0\nvn 0 0 1\nf 1//1 2//1 3//1\n");
    auto placed = [&](const std::string& keys) {
        return parse(scene_text(kCamera, kMaterials, R"({"mesh": "cm.obj", "material": "white", )" + keys + "}"),
                     dir.path.string());
    };
    // 1 cm = 0.01, a quarter turn about y (+x goes to -z), then 2 along x.
    const Scene s = placed(R"("scale": 0.01, "rotate": [0, 90, 0], "translate": [2, 0, 0])");
    REQUIRE(s.patch_count() == 1);
    const auto& p = s.patch_list()[0];
    const auto& pos = s.vertex_positions();
    CHECK((pos[p.v[0]] - Vec3(2, 0, 0)).norm() < 1e-12);
    CHECK((pos[p.v[1]] - Vec3(2, 0, -1)).norm() < 1e-12);
    CHECK((pos[p.v[2]] - Vec3(2, 0.5, 0)).norm() < 1e-12);
    CHECK(p.area == Approx(0.25));
    CHECK((p.normal - Vec3(1, 0, 0)).norm() < 1e-12);  // +z turned a quarter about y
    for (int k = 0; k < 3; ++k) CHECK((s.corner_normals()[0][k] - Vec3(1, 0, 0)).norm() < 1e-9);  // the file's, turned
    // Mirrored in x: the corners turn round, so the front stays +z.
    const Scene m = placed(R"("scale": [-0.01, 0.01, 0.01])");
    REQUIRE(m.patch_count() == 1);
    CHECK((m.patch_list()[0].normal - Vec3(0, 0, 1)).norm() < 1e-12);
    CHECK(m.patch_list()[0].area == Approx(0.25));
    CHECK_THROWS_WITH(placed(R"("scale": [1, 0, 1])"), "s.json: objects[0].scale: a factor of 0 flattens the mesh, got [1,0,1]");
    CHECK_THROWS_WITH(placed(R"("rotate": [0, 90])"), Catch::Contains("objects[0].rotate: expected [x, y, z]"));
    CHECK_THROWS_WITH(placed(R"("scale": 1e300, "rotate": [0, 45, 0])"),
                      "s.json: objects[0].scale: value 1e+300 is too large (at most 1e+15 in magnitude)");
    CHECK_THROWS_WITH(parse(scene_text(kCamera, kMaterials, R"({"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "white", "scale": 2})")),
                      "s.json: objects[0].scale: places a mesh object only (a quad's or triangle's corners are its place)");
}

TEST_CASE("zero-area triangles are dropped and counted", "[scenes]") {
    // A mesh's faces (a hand-typed "triangle" of no area is refused instead).
    TempDir dir;
    dir.write("line.obj", "v 0 0 1\nv 1 0 1\nv 2 0 1\nf 1 2 3\n");
    const std::string line = R"(, {"mesh": "line.obj", "material": "white"})";
    const Scene s = parse_scene(scene_text(kCamera, kMaterials, std::string(kQuad) + line), "s.json", dir.path.string());
    CHECK(s.patch_count() == 2);
    CHECK(s.dropped_degenerate == 1);
    // Found on the threads, dropped in face order: the same scene on 3 threads, with
    // zero-area triangles among many (a 20 x 20 grid of triangles, every 7th flat), each
    // a mesh of its own.
    std::string objects = kQuad;
    for (int k = 0; k < 400; ++k) {
        const double x = k % 20, y = k / 20, top = k % 7 == 0 ? 0.0 : 1.0;
        std::ostringstream obj;
        obj << "v " << x << " " << y << " 2\nv " << x + 1 << " " << y << " 2\nv " << x + top << " " << y + top
            << " 2\nf 1 2 3\n";
        const std::string name = "t" + std::to_string(k) + ".obj";
        dir.write(name, obj.str());
        objects += R"(, {"mesh": ")" + name + R"(", "material": "white"})";
    }
    LoadLimits limits;
    const Scene alone = parse_scene(scene_text(kCamera, kMaterials, objects), "s.json", dir.path.string(), {}, limits);
    limits.threads = 3;
    const Scene three = parse_scene(scene_text(kCamera, kMaterials, objects), "s.json", dir.path.string(), {}, limits);
    CHECK(alone.dropped_degenerate == 58);
    CHECK(three.dropped_degenerate == alone.dropped_degenerate);
    REQUIRE(three.patch_count() == alone.patch_count());
    bool same = three.vertex_positions() == alone.vertex_positions();
    for (std::size_t p = 0; p < alone.patch_count(); ++p)
        for (int k = 0; k < 3; ++k) same = same && three.patch_list()[p].v[k] == alone.patch_list()[p].v[k];
    CHECK(same);
}

TEST_CASE("bad scene input gives one clear error naming file, object and value", "[scenes][errors]") {
    TempDir dir;
    const std::string d = dir.path.string();
    auto fails_with = [&](const std::string& text, const std::string& needle) {
        INFO(text);
        REQUIRE_THROWS_AS(parse(text, d), SceneError);
        REQUIRE_THROWS_WITH(parse(text, d), Contains("s.json") && Contains(needle));
        try {
            parse(text, d);
        } catch (const SceneError& e) {
            CHECK(std::string(e.what()).find('\n') == std::string::npos);  // one line
        }
    };

    SECTION("missing file") {
        REQUIRE_THROWS_WITH(load_scene(d + "/nope.json"), Contains("nope.json") && Contains("cannot open"));
    }
    SECTION("malformed JSON names line and column") {
        fails_with("{\n  \"camera\": {\n    \"eye\": [0, 0,, 5]\n  }\n}", "s.json:3:");
    }
    SECTION("unknown keys are errors") {
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "patchsize": 2)"), "unknown key 'patchsize'");
        fails_with(scene_text(kCamera, R"("materials": {"white": {"albedo": [0.5,0.5,0.5], "emision": [1,1,1]}})", kQuad),
                   "materials.white: unknown key 'emision'");
        fails_with(scene_text(kCamera, kMaterials, R"({"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "white", "colour": 1})"),
                   "objects[0]: unknown key 'colour'");
        fails_with(scene_text(R"("camera": {"eye": [0,0,5], "target": [0,0,0], "fov": 40})", kMaterials, kQuad),
                   "camera: unknown key 'fov'");
    }
    SECTION("unknown material") {
        fails_with(scene_text(kCamera, kMaterials, R"({"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "red"})"),
                   "objects[0].material: unknown material 'red' (known: lamp, white)");
    }
    SECTION("non-finite coordinates") {
        fails_with(scene_text(kCamera, kMaterials, R"({"quad": [[0,0,0],[1e999,0,0],[1,1,0],[0,1,0]], "material": "white"})"),
                   "number overflow parsing '1e999' (not finite)");
        // Named by line and column (the parser gives no place; not "21e999" or "1e999"
        // in a string).
        const std::string text = scene_text(kCamera, kMaterials,
                                            "\n{\"name\": \"a \\\"1e999\", \"quad\": [[0,0,0],\n [1,0,0],[1,1,1e999],[0,1,0]], "
                                            "\"material\": \"white\"}, {\"name\": \"21e999\", \"quad\": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "
                                            "\"material\": \"white\"}");
        CHECK_THROWS_WITH(parse(text), "s.json:3:15: invalid number: number overflow parsing '1e999' (not finite)");
        dir.write("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "nan.obj", "material": "white"})"),
                   "nan.obj: line 2: coordinate 'nan' is not finite");
        dir.write("inf.off", "OFF\n3 1 0\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "inf.off", "material": "white"})"),
                   "inf.off: vertex 1: coordinate 'inf' is not finite");
    }
    SECTION("face index out of range") {
        dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "bad.obj", "material": "white"})"),
                   "objects[0].mesh: bad.obj: line 4: face references vertex 7, but only 3 vertices");
        dir.write("bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "bad.off", "material": "white"})"),
                   "bad.off: face 0: references vertex 3, but the file has 3 vertices");
    }
    SECTION("truncated mesh files") {
        dir.write("short.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "short.off", "material": "white"})"),
                   "short.off: vertices: file is truncated: header promises 4 vertices");
        dir.write("short.ply",
                  "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                  "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "short.ply", "material": "white"})"), "short.ply");
        fails_with(scene_text(kCamera, kMaterials, R"({"mesh": "missing.obj", "material": "white"})"),
                   "objects[0].mesh: missing.obj: cannot open mesh file");
    }
    SECTION("albedo + specular must stay below 1 in every channel") {
        fails_with(scene_text(kCamera,
                              R"("materials": {"white": {"albedo": [0.5,0.6,0.5], "specular": [0.3,0.4,0.3], "exponent": 20}})",
                              kQuad),
                   "materials.white: albedo + specular = 1 in channel g");
        fails_with(scene_text(kCamera, R"("materials": {"white": {"albedo": [1.2,0.5,0.5]}})", kQuad),
                   "albedo + specular = 1.2 in channel r");
    }
    SECTION("negative emission") {
        fails_with(scene_text(kCamera, R"("materials": {"white": {"albedo": [0.5,0.5,0.5], "emission": [1,-1,1]}})", kQuad),
                   "materials.white.emission: negative emission [1, -1, 1]");
    }
    SECTION("fov_y outside (0, 180)") {
        fails_with(scene_text(R"("camera": {"eye": [0,0,5], "target": [0,0,0], "fov_y": 180})", kMaterials, kQuad),
                   "camera.fov_y: must be in (0, 180) degrees, got 180");
        fails_with(scene_text(R"("camera": {"eye": [0,0,5], "target": [0,0,0], "fov_y": 0})", kMaterials, kQuad),
                   "camera.fov_y: must be in (0, 180) degrees, got 0");
    }
    SECTION("patch_size <= 0") {
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "patch_size": 0)"), "patch_size: must be a positive number, got 0");
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "patch_size": -1)"), "patch_size: must be a positive number, got -1");
    }
    SECTION("a scene with no patches") {
        fails_with(scene_text(kCamera, kMaterials, ""), "the scene has no patches");
        fails_with(scene_text(kCamera, kMaterials, R"({"triangle": [[0,0,0],[1,0,0],[2,0,0]], "material": "white"})"),
                   "objects[0].triangle: is degenerate: its points coincide or lie on one line");
    }
    SECTION("bad point lights and sky") {
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "point_lights": {"position": [0,0,1]})"),
                   "point_lights: expected an array, got object");
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "point_lights": [{"position": [0,0,1]}])"),
                   "point_lights[0].intensity: missing");
        fails_with(scene_text(kCamera, kMaterials, kQuad,
                              R"(, "point_lights": [{"position": [0,0,1], "intensity": [1,-1,1]}])"),
                   "point_lights[0].intensity: negative intensity [1, -1, 1]");
        fails_with(scene_text(kCamera, kMaterials, kQuad,
                              R"(, "point_lights": [{"position": [0,0,1], "intensity": [1,1,1], "radius": 2}])"),
                   "point_lights[0]: unknown key 'radius'");
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "sky": {"radiance": [1,1,1], "up": [0,0,0]})"),
                   "sky.up: is the zero vector");
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "sky": {"radiance": [1,1,1], "model": "clear"})"),
                   "sky.model: unknown sky model 'clear' (known: constant, overcast)");
        fails_with(scene_text(kCamera, kMaterials, kQuad, R"(, "sky": {"radiance": [1,-2,1]})"),
                   "sky.radiance: negative radiance");
    }
    SECTION("wrong types") {
        fails_with(scene_text(R"("camera": {"eye": [0,0,5], "target": [0,0,0], "fov_y": "wide"})", kMaterials, kQuad),
                   "camera.fov_y: expected a number, got string");
        fails_with(scene_text(R"("camera": {"eye": [0,0], "target": [0,0,0]})", kMaterials, kQuad),
                   "camera.eye: expected [x, y, z], got [0,0]");
    }
}

TEST_CASE("an error a -D setting made names the setting, not only the file", "[scenes][errors]") {
    const std::string text = scene_text(kCamera, kMaterials, kQuad);
    const auto message = [&](const Overrides& overrides) {
        try {
            parse_scene(text, "s.json", ".", overrides);
        } catch (const SceneError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    // At the setting's path, at the array it is an element of, or an unknown key.
    CHECK(message({{"camera.width", "abc"}}) == "s.json: camera.width: expected an integer, got \"abc\" (from -D camera.width=abc)");
    CHECK_THAT(message({{"camera.eye[1]", "nan"}}), Contains("camera.eye: ") && Contains("(from -D camera.eye[1]=nan)"));
    CHECK_THAT(message({{"materials.white.albdeo", "0.5"}}),
               Contains("materials.white: unknown key 'albdeo'") && Contains("(from -D materials.white.albdeo=0.5)"));
    CHECK_THAT(message({{"patch_sise", "3"}}), Contains("unknown key 'patch_sise'") && Contains("(from -D patch_sise=3)"));
    // The setting among others: the one at fault is named; of two, the last (it wins);
    // a setting given by its own flag is named so.
    CHECK_THAT(message({{"camera.width", "100"}, {"camera.fov_y", "200"}}),
               Contains("camera.fov_y: ") && Contains("(from -D camera.fov_y=200)") && !Contains("width"));
    CHECK_THAT(message({{"camera.fov_y", "50"}, {"camera.fov_y", "200"}}), Contains("got 200 (from -D camera.fov_y=200)"));
    CHECK_THAT(message({{"camera.fov_y", "50"}, {"camera.fov_y", "200", "--fov 200"}}), Contains("got 200 (from --fov 200)"));
    // A check of a material's values together, some of them set: "with" them all.
    CHECK_THAT(message({{"materials.white.albedo", "[0.9, 0.9, 0.9]"}, {"materials.white.specular", "[0.5, 0.5, 0.5]"},
                        {"materials.white.exponent", "10"}}),
               Contains("materials.white: albedo + specular") &&
                   Contains("(with -D materials.white.albedo=[0.9, 0.9, 0.9], -D materials.white.specular=[0.5, 0.5, 0.5], "
                            "-D materials.white.exponent=10)"));
    // An error the settings did not touch names none of them.
    const std::string bad = scene_text(kCamera, kMaterials, R"({"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "wood"})");
    try {
        parse_scene(bad, "s.json", ".", {{"camera.width", "100"}, {"materials.white.albedo", "[0.2, 0.2, 0.2]"}});
        FAIL("no error");
    } catch (const SceneError& e) {
        CHECK_THAT(e.what(), Contains("wood") && !Contains("-D"));
    }
}

TEST_CASE("built-in scenes", "[scenes]") {
    const Scene box = make_builtin("homogeneous-box");
    CHECK(box.exact_radiance == 1.0);
    CHECK(box.total_area() == Approx(6.0).epsilon(1e-12));
    const Scene cornell = make_builtin("cornell-box");
    CHECK(cornell.patch_count() > 3000);
    CHECK(cornell.patch_count() < 4500);
    CHECK(cornell.has_emission());
    const Scene terrain = make_builtin("fractal-terrain");
    CHECK(terrain.patch_count() > 14000);  // the paper's terrain has 14,712 patches
    CHECK(terrain.patch_count() < 15500);
    CHECK(terrain.has_emission());
    for (std::size_t i = 0; i < terrain.patch_count(); ++i)
        CHECK(terrain.patch_list()[i].normal.y() * (terrain.material_of(i).emissive() ? -1.0 : 1.0) > 0.0);
    CHECK(make_builtin("fractal-terrain", 1000.0).patch_count() == 2 * 23 * 23 + 2);  // 23 cells a side, + moon
    REQUIRE_THROWS_WITH(make_builtin("teapot"), Contains("unknown built-in scene 'teapot'") &&
                                                   Contains("homogeneous-box") && Contains("cornell-box"));
    REQUIRE_THROWS_WITH(make_builtin("cornell-box", 0.0), Contains("patch_size"));
}

TEST_CASE("coplanar overlaps: slivers across a disc are none, the same mesh twice is every pair, far away too",
          "[scenes]") {
    // An annulus of 500 segments from radius 0.05 to 1: 1,000 slivers 0.95 long and
    // under 0.013 wide, crossing many cells of the grids of the contact pass and the
    // overlap pass. Listed in every cell of their bounding boxes, the slivers filled
    // millions of cells (8,000 of them: 2 minutes, then bad_alloc).
    TempDir dir;
    std::string obj;
    const int n = 1100;  // twice: 4,400 patches in one plane
    const double pi = std::acos(-1.0);
    for (double offset : {0.0, 1e9}) {
        obj.clear();
        for (int i = 0; i < n; ++i) {
            const double a = 2 * pi * i / n;
            for (double r : {0.05, 1.0})
                obj += "v " + std::to_string(offset + r * std::cos(a)) + " " + std::to_string(r * std::sin(a)) + " 0\n";
        }
        for (int i = 0; i < n; ++i) {
            const int a = 2 * i + 1, b = 2 * i + 2, c = 2 * ((i + 1) % n) + 2, d = 2 * ((i + 1) % n) + 1;
            obj += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(c) + "\n";
            obj += "f " + std::to_string(a) + " " + std::to_string(c) + " " + std::to_string(d) + "\n";
        }
        dir.write("annulus.obj", obj);
        const std::string at = std::to_string(offset);
        const std::string head = R"({"camera": {"eye": [)" + at + R"(, 0, 3], "target": [)" + at +
                                 R"(, 0, 0]}, "patch_size": "none", "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [)";
        const std::string mesh = R"({"mesh": "annulus.obj", "material": "w"})";
        INFO("offset " << offset);
        const Scene once = parse_scene(head + mesh + "]}", "s.json", dir.path.string());
        REQUIRE(once.patch_count() == 2 * n);
        CHECK(coplanar_overlaps(once).pairs == 0);
        const Scene twice = parse_scene(head + mesh + ", " + mesh + "]}", "s.json", dir.path.string());
        const auto one = coplanar_overlaps(twice);
        CHECK(one.pairs == 2 * n);
        const auto three = coplanar_overlaps(twice, 3);
        CHECK(three.pairs == one.pairs);
        CHECK(three.first == one.first);
        CHECK(three.second == one.second);
    }
}

TEST_CASE("coplanar overlaps: a plane too wide for numbered cells (hashed keys) finds the same pairs", "[scenes]") {
    // Squares 1e-3 wide at the origin and at (1e9, 1e9) in one plane: about 1e24 cells of
    // the plane's grid, past what its cells can be numbered by (2^53), so the cells are
    // keyed by hashed coordinates. Each square twice: its 2 triangles overlap their
    // twins (the diagonals only touch), 4 pairs in all.
    Scene s;
    Material m;
    m.albedo = Rgb(0.5, 0.5, 0.5);
    const int w = s.add_material(m);
    const double a = 1e-3;
    for (const double at : {0.0, 1e9})
        for (int twice = 0; twice < 2; ++twice)
            s.add_object({Vec3(at, at, 0), Vec3(at + a, at, 0), Vec3(at + a, at + a, 0), Vec3(at, at + a, 0)},
                         {{0, 1, 2}, {0, 2, 3}}, w);
    s.finalize();
    REQUIRE(s.patch_count() == 8);
    const auto one = coplanar_overlaps(s);
    CHECK(one.pairs == 4);
    CHECK(one.first == 0);
    CHECK(one.second == 2);
    const auto three = coplanar_overlaps(s, 3);
    CHECK(three.pairs == one.pairs);
    CHECK(three.first == one.first);
    CHECK(three.second == one.second);
}

TEST_CASE("coplanar overlaps: a plane of long slivers, each given twice, finds each twin", "[scenes]") {
    // 400 slivers 1 long and 1e-7 wide across the plane's diagonal, side by side 1e-4
    // apart, each twice: 400 pairs. Cells two patches wide by area (4.5e-4) put each
    // sliver's box over 2.4 million of them; the cells are now the slivers' length.
    Scene s;
    Material m;
    m.albedo = Rgb(0.5, 0.5, 0.5);
    const int w = s.add_material(m);
    const Vec3 along = Vec3(1, 1, 0).normalized(), across(-along.y(), along.x(), 0);
    const int n = 400;
    for (int i = 0; i < n; ++i)
        for (int twice = 0; twice < 2; ++twice) {
            const Vec3 a = 1e-4 * i * across;
            s.add_object({a, a + along, a + 1e-7 * across}, {{0, 1, 2}}, w);
        }
    s.finalize();
    REQUIRE(s.patch_count() == 2 * n);
    const auto one = coplanar_overlaps(s);
    CHECK(one.pairs == n);
    CHECK(one.listings <= 8u * 2u * n);  // a few cells a sliver, not thousands along it
    const auto three = coplanar_overlaps(s, 3);
    CHECK(three.pairs == one.pairs);
    CHECK(three.first == one.first);
    CHECK(three.second == one.second);
}
