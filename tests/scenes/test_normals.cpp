// Shading normals: computed with a crease angle, read from OBJ `vn` and PLY nx/ny/nz,
// carried through subdivision, negated on two-sided twins; bad normals in files.
#include "scenes/builtin.h"
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "tests/scenes/uv_sphere.h"

#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

namespace fs = std::filesystem;
using namespace raybundle::scenes;
using raybundle::test::degrees_between;
using raybundle::test::obj_text;
using raybundle::test::ply_text;
using raybundle::test::uv_sphere;
using Catch::Matchers::Contains;

using raybundle::test::TempDir;

namespace {

// A scene of the given objects (JSON), with `extra` root keys: the patches as modelled
// unless they give a patch size.
std::string scene_text(const std::string& objects, const std::string& extra = "") {
    const std::string size = extra.find("\"patch_size\"") == std::string::npos ? ", \"patch_size\": \"none\"" : "";
    return R"({"camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
               "materials": {"white": {"albedo": [0.5, 0.5, 0.5]}, "both": {"albedo": [0.5, 0.5, 0.5], "two_sided": true}},
               "objects": [)" +
           objects + "]" + extra + size + "}";
}

Scene load(const TempDir& dir, const std::string& objects, const std::string& extra = "") {
    return parse_scene(scene_text(objects, extra), "s.json", dir.path.string());
}

// At random points of every patch of the unit sphere about the origin: the largest
// angle (degrees) of the shading normal and of the patch normal from the sphere's
// normal at the point's direction.
struct SphereErrors {
    double shading = 0.0, geometric = 0.0;
};
SphereErrors sphere_errors(const Scene& s) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    SphereErrors e;
    const auto& pos = s.vertex_positions();
    for (std::size_t i = 0; i < s.patch_count(); ++i) {
        const Patch& p = s.patch_list()[i];
        for (int n = 0; n < 8; ++n) {
            double b1 = u(rng), b2 = u(rng);
            if (b1 + b2 > 1.0) b1 = 1.0 - b1, b2 = 1.0 - b2;
            const Vec3 x = (1.0 - b1 - b2) * pos[p.v[0]] + b1 * pos[p.v[1]] + b2 * pos[p.v[2]];
            const Vec3 exact = x.normalized();
            const Vec3 shading = s.shading_normal(i, b1, b2);
            REQUIRE(shading.norm() == Approx(1.0).epsilon(1e-12));
            e.shading = std::max(e.shading, degrees_between(shading, exact));
            e.geometric = std::max(e.geometric, degrees_between(p.normal, exact));
        }
    }
    return e;
}

}  // namespace

TEST_CASE("shading normals of a tessellated sphere follow the sphere, its patch normals do not", "[scenes][normals]") {
    TempDir dir;
    const auto sphere = uv_sphere(24, 12);
    dir.write("plain.obj", obj_text(sphere, false));
    dir.write("vn.obj", obj_text(sphere, true));
    dir.write("normals.ply", ply_text(sphere));

    SECTION("computed (no normals in the file), 30 degree crease") {
        const Scene s = load(dir, R"({"mesh": "plain.obj", "material": "white"})");
        REQUIRE(s.patch_count() == sphere.triangles.size());
        // Measured: shading 0.60 degrees at most, patch normals 10.3.
        const SphereErrors e = sphere_errors(s);
        CHECK(e.geometric > 10.0);
        CHECK(e.shading < 1.0);
    }
    SECTION("OBJ vn") {
        const Scene s = load(dir, R"({"mesh": "vn.obj", "material": "white"})");
        // The exact normals at the vertices of the unit sphere, interpolated and
        // normalised, are the exact normal of the point (measured: 1.5e-14 degrees).
        const SphereErrors e = sphere_errors(s);
        CHECK(e.geometric > 10.0);
        CHECK(e.shading < 1e-9);
        // The file's normals at the corners, in the order of the patch's vertices.
        for (std::size_t i = 0; i < s.patch_count(); ++i)
            for (int k = 0; k < 3; ++k) {
                const Vec3& x = s.vertex_positions()[s.patch_list()[i].v[k]];
                CHECK((s.corner_normals()[i][k] - x.normalized()).norm() < 1e-12);
                CHECK((s.shading_normal(i, k == 1, k == 2) - x.normalized()).norm() < 1e-12);
            }
    }
    SECTION("PLY nx, ny, nz") {
        const Scene s = load(dir, R"({"mesh": "normals.ply", "material": "white"})");
        // Float coordinates and normals (OpenMesh reads PLY as float): measured 2.1e-7 degrees.
        const SphereErrors e = sphere_errors(s);
        CHECK(e.geometric > 10.0);
        CHECK(e.shading < 1e-5);
    }
    SECTION("refined by patch_size: the normals carried through subdivision stay smooth") {
        for (const char* mesh : {"plain.obj", "vn.obj", "normals.ply"}) {
            INFO(mesh);
            const Scene s = load(dir, std::string(R"({"mesh": ")") + mesh + R"(", "material": "white"})",
                                 R"(, "patch_size": 0.05)");
            CHECK(s.patch_count() > 10 * sphere.triangles.size());
            // 28,032 patches. Measured: shading 0.61 degrees (computed), 0.047 (the
            // file's: the mean at a midpoint is not the sphere's normal there);
            // patch normals 10.5, since the fine patches lie in the coarse facets.
            const SphereErrors e = sphere_errors(s);
            CHECK(e.geometric > 10.0);
            CHECK(e.shading < (std::string(mesh) == "plain.obj" ? 1.0 : 0.1));
        }
    }
    SECTION("crease_angle 0 gives flat normals, globally or per object") {
        for (const auto& [objects, extra] :
             {std::pair<std::string, std::string>{R"({"mesh": "plain.obj", "material": "white"})", R"(, "crease_angle": 0)"},
              {R"({"mesh": "plain.obj", "material": "white", "crease_angle": 0})", ""},
              {R"({"mesh": "plain.obj", "material": "white", "crease_angle": 0})", R"(, "crease_angle": 90, "patch_size": 0.1)"}}) {
            INFO(objects << extra);
            const Scene s = load(dir, objects, extra);
            for (std::size_t i = 0; i < s.patch_count(); ++i) {
                const Vec3& n = s.patch_list()[i].normal;
                for (int k = 0; k < 3; ++k) REQUIRE(s.corner_normals()[i][k] == n);
                REQUIRE(s.shading_normal(i, 0.2, 0.3) == n);
            }
        }
    }
    SECTION("\"normals\": \"computed\" ignores the file's") {
        const Scene file = load(dir, R"({"mesh": "vn.obj", "material": "white"})");
        const Scene computed = load(dir, R"({"mesh": "vn.obj", "material": "white", "normals": "computed"})");
        const Scene plain = load(dir, R"({"mesh": "plain.obj", "material": "white"})");
        CHECK(computed.corner_normals() == plain.corner_normals());
        CHECK(computed.corner_normals() != file.corner_normals());
    }
    SECTION("two-sided: the twins have the negated normals") {
        // Refinement may split a twin differently where edges are equally long (the
        // order of the split among ties follows the edges' order in the mesh, which the
        // reversed triangles change): compare the patches that coincide.
        for (const char* extra : {"", R"(, "patch_size": 0.2)"})
            for (const char* mesh : {"plain.obj", "vn.obj", "normals.ply"}) {
                INFO(mesh << extra);
                const Scene s = load(dir, std::string(R"({"mesh": ")") + mesh + R"(", "material": "both"})", extra);
                const auto& patches = s.patch_list();
                const auto& pos = s.vertex_positions();
                // Every outward patch has its twin: the same corners, turned over.
                std::size_t outward = 0, twins = 0;
                double worst = 0.0;
                for (std::size_t i = 0; i < patches.size(); ++i) {
                    if (patches[i].normal.dot(patches[i].centroid) < 0.0) continue;
                    ++outward;
                    for (std::size_t j = 0; j < patches.size(); ++j) {
                        if (j == i || (patches[i].centroid - patches[j].centroid).norm() > 1e-12) continue;
                        ++twins;
                        for (int k = 0; k < 3; ++k)
                            for (int l = 0; l < 3; ++l)
                                if (pos[patches[i].v[k]] == pos[patches[j].v[l]])
                                    worst = std::max(worst, (s.corner_normals()[i][k] + s.corner_normals()[j][l]).norm());
                    }
                }
                CHECK(2 * outward == patches.size());
                CHECK(twins >= (std::string(extra).empty() ? outward : outward * 99 / 100));
                CHECK(worst < 1e-12);
            }
    }
}

TEST_CASE("a split edge's new vertex gets, in each face, the mean of the edge's corner normals", "[scenes][normals][subdivide]") {
    TempDir dir;
    // Two triangles on the edge (0,0,0)-(2,0,0), each with its own normals at its
    // corners; patch_size 1.5 splits that edge and no other.
    const Vec3 a1(0.3, 0, 1), a2(-0.3, 0, 1), a3(0, 0.3, 1), b1(0.2, 0.1, 1), b2(-0.1, 0.2, 1), b4(0, -0.3, 1);
    auto text = [](const Vec3& n) {
        std::ostringstream os;
        os.precision(17);
        os << "vn " << n.x() << ' ' << n.y() << ' ' << n.z() << '\n';
        return os.str();
    };
    dir.write("pair.obj", "v 0 0 0\nv 2 0 0\nv 1 1 0\nv 1 -1 0\n" + text(a1) + text(a2) + text(a3) + text(b1) + text(b2) +
                              text(b4) + "f 1//1 2//2 3//3\nf 2//5 1//4 4//6\n");
    const Scene s = load(dir, R"({"mesh": "pair.obj", "material": "white"})", R"(, "patch_size": 1.5)");
    REQUIRE(s.patch_count() == 4);
    const auto& pos = s.vertex_positions();
    for (std::size_t i = 0; i < 4; ++i) {
        const Patch& p = s.patch_list()[i];
        const bool upper = p.centroid.y() > 0.0;
        for (int k = 0; k < 3; ++k) {
            const Vec3& x = pos[p.v[k]];
            Vec3 expected;
            if (x == Vec3(1, 0, 0))
                expected = upper ? (a1.normalized() + a2.normalized()).normalized()
                                 : (b1.normalized() + b2.normalized()).normalized();
            else if (x == Vec3(0, 0, 0))
                expected = (upper ? a1 : b1).normalized();
            else if (x == Vec3(2, 0, 0))
                expected = (upper ? a2 : b2).normalized();
            else
                expected = (upper ? a3 : b4).normalized();
            INFO("patch " << i << " corner " << x.transpose());
            CHECK((s.corner_normals()[i][k] - expected).norm() < 1e-15);
        }
    }
}

TEST_CASE("flat objects keep their exact face normals", "[scenes][normals]") {
    TempDir dir;
    // A cube with shared corners: the 90 degree edges are creases.
    dir.write("cube.obj",
              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
    const std::string quad = R"({"quad": [[0,0,-1], [2,0,-1], [2,2,-1], [0,2,-1]], "material": "white"})";
    for (const char* extra : {"", R"(, "patch_size": 0.3)"}) {
        INFO(extra);
        const Scene s = load(dir, R"({"mesh": "cube.obj", "material": "white"}, )" + quad, extra);
        for (std::size_t i = 0; i < s.patch_count(); ++i) {
            const Vec3& n = s.patch_list()[i].normal;
            for (int k = 0; k < 3; ++k) REQUIRE(s.corner_normals()[i][k] == n);
            REQUIRE(s.shading_normal(i, 0.25, 0.5) == n);
        }
    }
    // With a crease angle above 90 degrees the cube's corners are smoothed.
    const Scene round = load(dir, R"({"mesh": "cube.obj", "material": "white", "crease_angle": 100})");
    const Vec3 corner = round.corner_normals()[0][0];
    CHECK(std::abs(corner.x()) == Approx(1 / std::sqrt(3.0)));
    CHECK(std::abs(corner.y()) == Approx(1 / std::sqrt(3.0)));
    CHECK(std::abs(corner.z()) == Approx(1 / std::sqrt(3.0)));
    // The built-in Cornell box: no smoothing across the blocks' edges. The blocks'
    // sides are slightly out of plane, as in the original data, so the triangles of a
    // side do share normals, up to 0.24 degrees from their own (measured).
    const Scene box = make_builtin("cornell-box");
    for (std::size_t i = 0; i < box.patch_count(); ++i)
        for (int k = 0; k < 3; ++k)
            REQUIRE(degrees_between(box.corner_normals()[i][k], box.patch_list()[i].normal) < 1.0);
}

TEST_CASE("the shading normal is never on the back of its patch", "[scenes][normals]") {
    TempDir dir;
    // One triangle facing +z whose file normals face -z, and one whose corners tilt.
    dir.write("back.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 -1\nf 1//1 2//1 3//1\n");
    dir.write("tilt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 0 0.1\nvn 0 1 0.1\nvn -1 -1 -0.5\nf 1//1 2//2 3//3\n");
    const Scene back = load(dir, R"({"mesh": "back.obj", "material": "white"})");
    CHECK(back.corner_normals()[0][0] == Vec3(0, 0, -1));  // kept as given
    CHECK(back.shading_normal(0, 0.3, 0.3) == Vec3(0, 0, 1));
    const Scene tilt = load(dir, R"({"mesh": "tilt.obj", "material": "white"})");
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 1000; ++n) {
        const double b1 = u(rng), b2 = (1.0 - b1) * u(rng);
        const Vec3 s = tilt.shading_normal(0, b1, b2);
        REQUIRE(s.z() >= 0.0);
        REQUIRE(s.norm() == Approx(1.0));
    }
    // At corner 2 the file normal points down: turned over.
    CHECK(tilt.shading_normal(0, 0.0, 1.0).z() > 0.0);
}

TEST_CASE("a normal of zero length, as exporters write at degenerate faces: its corners computed", "[scenes][normals]") {
    TempDir dir;
    // A triangle facing +z: the file tilts two corners, and gives the first (0, 0, 0).
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    dir.write("zero.obj", tri + "v 1 1 0\nvn 0 0 0\nvn 0 0.6 0.8\nvn 0 0 0\nf 1//1 2//2 3//2\nf 2//3 4//2 3//2\n");
    const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                               "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                               "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    dir.write("zero.ply", header + "0 0 0 0 0 0\n1 0 0 0 0.6 0.8\n0 1 0 0 0.6 0.8\n3 0 1 2\n");
    // MSVC writes a normal that is not finite as -1.#IND00; others as nan.
    dir.write("nan.obj", tri + "v 1 1 0\nvn -1.#IND00 -1.#IND00 -1.#IND00\nvn 0 0.6 0.8\nvn -nan(ind) 0 0\n"
                               "f 1//1 2//2 3//2\nf 2//3 4//2 3//2\n");
    for (const std::string file : {"zero.obj", "zero.ply", "nan.obj"}) {
        INFO(file);
        const Scene scene = load(dir, R"({"mesh": ")" + file + R"(", "material": "white", "crease_angle": 0})");
        REQUIRE(scene.patch_count() >= 1);
        int computed = 0, given = 0;
        for (const Vec3& n : scene.corner_normals()[0]) {
            computed += n.isApprox(Vec3(0, 0, 1));
            given += n.isApprox(Vec3(0, 0.6, 0.8));
        }
        CHECK(computed == 1);
        CHECK(given == 2);
        REQUIRE(scene.warnings.size() == 1);
        CHECK(scene.warnings[0] ==
              (file == "zero.obj"   ? "zero.obj: 2 normals of zero length (the first at line 5): the corners that use them get "
                                      "computed normals"
               : file == "nan.obj" ? "nan.obj: 2 normals not finite (the first at line 5): the corners that use them get "
                                      "computed normals"
                                    : "zero.ply: a normal of zero length (at vertex 0): the corners that use it get a "
                                      "computed normal"));
    }
}

TEST_CASE("bad normals and normal keys give one clear error", "[scenes][normals][errors]") {
    TempDir dir;
    auto fails_with = [&](const std::string& objects, const std::string& extra, const std::string& needle) {
        INFO(objects << extra);
        REQUIRE_THROWS_AS(load(dir, objects, extra), SceneError);
        REQUIRE_THROWS_WITH(load(dir, objects, extra), Contains("s.json") && Contains(needle));
        try {
            load(dir, objects, extra);
        } catch (const SceneError& e) {
            CHECK(std::string(e.what()).find('\n') == std::string::npos);
        }
    };
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    auto mesh = [](const std::string& file, const std::string& more = "") {
        return R"({"mesh": ")" + file + R"(", "material": "white")" + more + "}";
    };
    dir.write("word.obj", tri + "vn 0 x 1\nf 1//1 2//1 3//1\n");
    fails_with(mesh("word.obj"), "", "objects[0].mesh: word.obj: line 4: normal coordinate 'x' is not a number");
    dir.write("short.obj", tri + "vn 0 0\nf 1//1 2//1 3//1\n");
    fails_with(mesh("short.obj"), "", "short.obj: line 4: normal has fewer than 3 coordinates");
    dir.write("range.obj", tri + "vn 0 0 1\nf 1//1 2//1 3//2\n");
    fails_with(mesh("range.obj"), "", "range.obj: line 5: face references normal 2, but only 1 normal is defined before it");
    dir.write("mixed.obj", tri + "vn 0 0 1\nf 1//1 2 3//1\n");
    fails_with(mesh("mixed.obj"), "", "mixed.obj: line 5: face gives normals at 2 of its 3 corners");
    dir.write("garbled.obj", tri + "vn 0 0 1\nf 1//x 2//1 3//1\n");
    fails_with(mesh("garbled.obj"), "", "garbled.obj: line 5: malformed face corner '1//x'");

    const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    const std::string faces = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    dir.write("two.ply", header + "property float nx\nproperty float ny\n" + faces + "0 0 0 0 0\n1 0 0 0 0\n0 1 0 0 0\n3 0 1 2\n");
    fails_with(mesh("two.ply"), "", "two.ply: header: vertex normals need all of nx, ny, nz (found nx, ny)");

    dir.write("plain.obj", tri + "f 1 2 3\n");
    fails_with(mesh("plain.obj", R"(, "normals": "file")"), "", "objects[0].normals: 'file', but plain.obj has no normals");
    fails_with(mesh("plain.obj", R"(, "normals": "smooth")"), "",
               "objects[0].normals: unknown normals 'smooth' (known: auto, file, computed)");
    fails_with(R"({"triangle": [[0,0,0], [1,0,0], [0,1,0]], "material": "white", "normals": "computed"})", "",
               "objects[0].normals: only a mesh object has a choice of normals");
    fails_with(mesh("plain.obj", R"(, "crease_angle": 200)"), "", "objects[0].crease_angle: must be in [0, 180] degrees, got 200");
    fails_with(mesh("plain.obj"), R"(, "crease_angle": -1)", "crease_angle: must be in [0, 180] degrees, got -1");
    fails_with(mesh("plain.obj"), R"(, "crease_angle": "flat")", "crease_angle: expected a number, got string");
}
