// OBJ files with their materials (issue 28): usemtl, o/g and mtllib read; MTL files
// parsed and refused in one line; a mesh without "material" takes its MTL's, the
// scene's materials override by name; an OBJ file alone is a scene.
#include "render/image_io.h"
#include "scenes/diagnostics.h"
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "scenes/mesh_file.h"

#include "png_bytes.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>
#include <cstdio>  // before jpeglib.h, which uses FILE and size_t

#include <jpeglib.h>

#include <algorithm>
#include <cmath>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace raybundle::scenes;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using raybundle::test::TempDir;

namespace {

// Two quads on the floor and a light above them, in two groups, three materials.
const char* kObj = "mtllib room.mtl\n"
                   "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 2 0 0\nv 2 0 1\n"
                   "v 0 1 0\nv 1 1 0\nv 1 1 1\nv 0 1 1\n"
                   "g floor\nusemtl red\nf 1 4 3 2\nusemtl green\nf 2 3 6 5\n"
                   "g lamp\nusemtl lamp\nf 7 8 9 10\n";
const char* kMtl = "# a comment\nnewmtl red\nKd 0.6 0.1 0.1\nKa 0 0 0\nd 1\n"
                   "newmtl green\nKd 0.1 0.6 0.1\nKs 0.2 0.2 0.2\nNs 20\nillum 2\n"
                   "newmtl lamp\nKd 0 0 0\nKe 5 4 3\n";

std::string scene_with(const std::string& objects, const std::string& materials = "") {
    return std::string(R"({"camera": {"eye": [1, 3, 4], "target": [1, 0, 0.5]}, "patch_size": "none", )") +
           (materials.empty() ? "" : R"("materials": {)" + materials + "}, ") + R"("objects": [)" + objects + "]}";
}

}  // namespace

TEST_CASE("OBJ: usemtl, groups and mtllib are recorded per triangle", "[scenes][mesh][obj]") {
    const MeshData d = parse_mesh(kObj, "obj", "room.obj");
    REQUIRE(d.triangles.size() == 6);
    CHECK(d.materials == std::vector<std::string>{"red", "green", "lamp"});
    CHECK(d.groups == std::vector<std::string>{"floor", "lamp"});
    CHECK(d.material_libraries == std::vector<std::string>{"room.mtl"});
    CHECK(d.triangle_material == std::vector<int>{0, 0, 1, 1, 2, 2});
    CHECK(d.triangle_group == std::vector<int>{0, 0, 0, 0, 1, 1});
    // Without any of them the lists stay empty; faces before the first usemtl are -1.
    CHECK(parse_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj", "t.obj").triangle_material.empty());
    const MeshData late = parse_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl a\nf 1 2 3\n", "obj", "t.obj");
    CHECK(late.triangle_material == std::vector<int>{-1, 0});
    CHECK_THROWS_WITH(parse_mesh("usemtl\n", "obj", "t.obj"), Contains("t.obj") && Contains("line 1") && Contains("usemtl"));
}

TEST_CASE("OBJ as exporters write it: trailing comments, several MTL files on one line, Windows folders",
          "[scenes][mesh][obj]") {
    // A comment after a blank ends a statement of numbers; a name keeps its '#' (3ds
    // Max names materials "Material #25", in its MTL too).
    const MeshData d = parse_mesh("mtllib a.mtl b.MTL\nv 0 0 0 # origin\nv 1 0 0\n  v 0 1 0\t# indented\n"
                                  "usemtl Material #25\nf 1 2 3 # a face\nusemtl wall#2\nf 1 2 3\n",
                                  "obj", "t.obj");
    CHECK(d.material_libraries == std::vector<std::string>{"a.mtl", "b.MTL"});
    CHECK(d.materials == std::vector<std::string>{"Material #25", "wall#2"});
    CHECK(d.triangles.size() == 2);
    // One name with spaces stays one; a Windows folder's backslashes are slashes.
    const std::string face = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    CHECK(parse_mesh("mtllib my room.mtl\n" + face, "obj", "t.obj").material_libraries ==
          std::vector<std::string>{"my room.mtl"});
    CHECK(parse_mesh("mtllib sub\\room.mtl\n" + face, "obj", "t.obj").material_libraries ==
          std::vector<std::string>{"sub/room.mtl"});
}

TEST_CASE("OBJ: a face given twice the same way round is kept once, the other way round twice", "[scenes][obj]") {
    // The boxes of McGuire's Cornell box OBJ end with a "bottom face" that repeats the
    // right (back) face's vertices: two patches in one place facing one way, of which
    // every visibility map sees one, so that the other stayed dark in the solved field
    // and the floor in front of it came out 8-10 % too dark where gather rays met it.
    TempDir dir;
    // A triangle, itself rotated twice (both dropped) and its back (kept).
    dir.write("box.obj", "mtllib w.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n"
                         "usemtl w\nf 1 4 3\nf 4 3 1\nf 1 3 4\nf 3 1 4\n");
    dir.write("w.mtl", "newmtl w\nKd 0.5 0.5 0.5\n");
    const std::string head = R"({"camera": {"eye": [0.5, 3, 2], "target": [0.5, 0, 0.5]}, "patch_size": "none", )"
                             R"("objects": [)";
    const Scene s = parse_scene(head + R"({"mesh": "box.obj"}]})", "s.json", dir.path.string());
    CHECK(s.patch_count() == 2);
    REQUIRE(s.warnings.size() == 1);
    CHECK_THAT(s.warnings[0], Contains("box.obj") && Contains("2 triangles given twice") && Contains("dropped"));
    CHECK(s.patch_list()[0].normal.dot(s.patch_list()[1].normal) == Approx(-1.0));
    CHECK(coplanar_overlaps(s).pairs == 0);
}

TEST_CASE("MTL: the colours a material uses are read, malformed ones refused with file and line", "[scenes][mtl]") {
    const auto mats = parse_mtl(kMtl, "room.mtl");
    REQUIRE(mats.size() == 3);
    CHECK(mats[0].name == "red");
    CHECK(mats[0].kd.isApprox(Rgb(0.6, 0.1, 0.1)));
    CHECK(mats[1].ks.isApprox(Rgb(0.2, 0.2, 0.2)));
    CHECK(mats[1].ns == 20.0);
    CHECK(mats[1].illum == 2);
    CHECK(mats[2].ke.isApprox(Rgb(5, 4, 3)));
    CHECK(parse_mtl("newmtl g\nKd 0.5\nmap_Kd -s 1 1 1 tex/wood.png\n", "m.mtl")[0].map_kd == "tex/wood.png");
    CHECK(parse_mtl("newmtl g\n", "m.mtl")[0].kd.isApprox(Rgb::Constant(0.8)));  // none given
    CHECK(parse_mtl("newmtl g\n  Kd 0.63 0.065 0.05 # Red\n", "m.mtl")[0].kd.isApprox(Rgb(0.63, 0.065, 0.05)));
    auto fails = [](const std::string& text, const std::string& needle) {
        INFO(text);
        CHECK_THROWS_WITH(parse_mtl(text, "m.mtl"), Contains("m.mtl") && Contains("line") && Contains(needle));
    };
    fails("Kd 1 1 1\n", "before the first newmtl");
    fails("newmtl a\nKd 1 nan 1\n", "not a finite number");
    fails("newmtl a\nKd 1 1\n", "expected 3 numbers");
    fails("newmtl a\nKe -1 0 0\n", "negative colour");
    fails("newmtl a\nNs -2\n", "Ns");
    fails("newmtl a\nillum 2.5\n", "illum");
    fails("newmtl a\nnewmtl b\nnewmtl a\n", "defined twice (first on line 1)");
    fails("newmtl\n", "without a name");
}

TEST_CASE("OBJ + MTL in a scene: the mesh's materials, overridden by the scene's by name", "[scenes][obj]") {
    TempDir dir;
    dir.write("room.obj", kObj);
    dir.write("room.mtl", kMtl);
    const Scene scene = parse_scene(scene_with(R"({"mesh": "room.obj"})"), "s.json", dir.path.string());
    REQUIRE(scene.materials.size() == 3);
    const Material& lamp = scene.materials[static_cast<std::size_t>(scene.find_material("lamp"))];
    CHECK(lamp.emission.isApprox(Rgb(5, 4, 3)));
    const Material& green = scene.materials[static_cast<std::size_t>(scene.find_material("green"))];
    CHECK(green.specular.isApprox(Rgb::Constant(0.2)));
    CHECK(green.exponent == 20.0);
    // One object per material (named by it), the MTL among the files read.
    CHECK(scene.object_names == std::vector<std::string>{"objects[0] (room.obj: red)", "objects[0] (room.obj: green)",
                                                         "objects[0] (room.obj: lamp)"});
    CHECK(std::find(scene.files.begin(), scene.files.end(), dir.path.string() + "/room.mtl") != scene.files.end());
    CHECK(scene.warnings.empty());
    // The scene's own "red" wins over the MTL's.
    const Scene over = parse_scene(scene_with(R"({"mesh": "room.obj", "name": "room"})", R"("red": {"albedo": [0.3, 0.3, 0.3]})"),
                                   "s.json", dir.path.string());
    CHECK(over.materials[static_cast<std::size_t>(over.find_material("red"))].albedo.isApprox(Rgb::Constant(0.3)));
    CHECK(over.object_names.front() == "room: red");
    // A "material" given: the whole mesh has it, as before.
    const Scene one = parse_scene(scene_with(R"({"mesh": "room.obj", "material": "w"})", R"("w": {"albedo": [0.5, 0.5, 0.5]})"),
                                  "s.json", dir.path.string());
    CHECK(one.materials.size() == 1);
    CHECK(one.object_names.size() == 1);
}

TEST_CASE("OBJ + MTL: two assets' materials of one name are one where they agree, two where they differ",
          "[scenes][obj]") {
    // Blender names every default material "Material": two exported assets both have one.
    TempDir dir;
    const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nusemtl Material\nf 1 4 3 2\n";
    dir.write("a.obj", "mtllib a.mtl\n" + quad);
    dir.write("a.mtl", "newmtl Material\nKd 0.8 0.1 0.1\nKs 0.5 0.5 0.5\nNs 10\nillum 2\n");  // scaled: a warning
    dir.write("b.obj", "mtllib b.mtl\n" + quad);
    dir.write("b.mtl", "newmtl Material\nKd 0.1 0.1 0.8\n");
    dir.write("c.obj", "mtllib a.mtl\n" + quad);  // the same MTL as a.obj
    const Scene two = parse_scene(scene_with(R"({"mesh": "a.obj"}, {"mesh": "b.obj", "translate": [2, 0, 0]})"), "s.json",
                                  dir.path.string());
    REQUIRE(two.materials.size() == 2);
    CHECK(two.materials[0].name == "Material");
    CHECK(two.materials[0].albedo[0] > 0.5);  // a's red (scaled with its Ks)
    CHECK(two.materials[1].name == "Material (b.obj)");
    CHECK(two.materials[1].albedo.isApprox(Rgb(0.1, 0.1, 0.8)));
    CHECK(two.object_names.back() == "objects[1] (b.obj: Material (b.obj))");
    REQUIRE(two.warnings.size() == 2);  // a's scaling, then the renaming
    CHECK(two.warnings[1] == "b.obj: its material 'Material' differs from the one of that name an earlier mesh brought: "
                             "it is 'Material (b.obj)' here (-D 'materials[\"Material (b.obj)\"]={...}' sets it)");
    // That name, dot and all, is the scene's to define: -D names it in brackets.
    const std::string both = scene_with(R"({"mesh": "a.obj"}, {"mesh": "b.obj", "translate": [2, 0, 0]})");
    const Scene set = parse_scene(both, "s.json", dir.path.string(),
                                  {{"materials[\"Material (b.obj)\"]", R"({"albedo": [0.2, 0.7, 0.2]})", ""}});
    REQUIRE(set.find_material("Material (b.obj)") >= 0);
    CHECK(set.materials[static_cast<std::size_t>(set.find_material("Material (b.obj)"))].albedo.isApprox(Rgb(0.2, 0.7, 0.2)));
    CHECK(set.materials[static_cast<std::size_t>(set.find_material("Material"))].albedo[0] > 0.5);  // a's, as it was
    CHECK(set.object_names.back() == "objects[1] (b.obj: Material (b.obj))");
    CHECK(set.warnings.size() == 1);  // no renaming: the scene's own material is b's
    CHECK_THROWS_WITH(parse_scene(both, "s.json", dir.path.string(), {{"materials[\"Material (b.obj)", "1", ""}}),
                      Contains("malformed key in -D materials[\"Material (b.obj) (no closing \"])"));
    CHECK_THROWS_WITH(parse_scene(both, "s.json", dir.path.string(), {{"materials[\"Material (b.obj)\"]albedo", "1", ""}}),
                      Contains("(a '.' or '[' after \"])"));
    CHECK_THROWS_WITH(parse_scene(both, "s.json", dir.path.string(), {{"materials[\"\"]", "{}", ""}}),
                      Contains("(an empty name)"));
    // Some values of "Material" edit each asset's own: both glow, each keeps its colour.
    const auto named = [](const Scene& s, const std::string& name) -> const Material& {
        REQUIRE(s.find_material(name) >= 0);
        return s.materials[static_cast<std::size_t>(s.find_material(name))];
    };
    const Scene glow = parse_scene(both, "s.json", dir.path.string(), {{"materials.Material.emission", "[1, 1, 1]", ""}});
    REQUIRE(glow.materials.size() == 2);
    CHECK(named(glow, "Material").albedo[0] > 0.5);
    CHECK(named(glow, "Material").emission.isApprox(Rgb::Ones()));
    CHECK(named(glow, "Material (b.obj)").albedo.isApprox(Rgb(0.1, 0.1, 0.8)));
    CHECK(named(glow, "Material (b.obj)").emission.isApprox(Rgb::Ones()));
    // The renamed one by its name: b's alone.
    const Scene one = parse_scene(both, "s.json", dir.path.string(), {{"materials[\"Material (b.obj)\"].emission", "[2, 2, 2]", ""}});
    REQUIRE(one.materials.size() == 2);
    CHECK(named(one, "Material").emission.isApprox(Rgb::Zero()));
    CHECK(named(one, "Material (b.obj)").emission.isApprox(Rgb::Constant(2)));
    CHECK(named(one, "Material (b.obj)").albedo.isApprox(Rgb(0.1, 0.1, 0.8)));
    // A lobe given to a diffuse material needs its exponent.
    CHECK_THROWS_WITH(parse_scene(both, "s.json", dir.path.string(), {{"materials[\"Material (b.obj)\"].specular", "[0.1, 0.1, 0.1]", ""}}),
                      Contains("exponent: missing (a material with specular needs it)"));
    // An object that names an edited material before any mesh brings it: a material of
    // its own, which needs its albedo.
    const std::string first = scene_with(R"({"quad": [[0,0,3], [1,0,3], [1,1,3], [0,1,3]], "material": "Material"}, {"mesh": "a.obj"})");
    CHECK_THROWS_WITH(parse_scene(first, "s.json", dir.path.string(), {{"materials.Material.emission", "[1, 1, 1]", ""}}),
                      Contains("materials.Material: no material 'Material' for -D to change a value of: objects[0] names "
                               "it before any mesh brings one (a new material needs its albedo)"));
    // The same material twice is one, its warnings given once.
    const Scene same = parse_scene(scene_with(R"({"mesh": "a.obj"}, {"mesh": "c.obj", "translate": [2, 0, 0]})"), "s.json",
                                   dir.path.string());
    CHECK(same.materials.size() == 1);
    CHECK(same.warnings.size() == 1);
    // The scene file's own material of that name replaces both.
    const Scene over = parse_scene(scene_with(R"({"mesh": "a.obj"}, {"mesh": "b.obj", "translate": [2, 0, 0]})",
                                              R"("Material": {"albedo": [0.3, 0.3, 0.3]})"),
                                   "s.json", dir.path.string());
    CHECK(over.materials.size() == 1);
    CHECK(over.warnings.empty());
    // Emission past 1e15, which a scene file's material may not have, is refused too.
    dir.write("hot.obj", "mtllib hot.mtl\n" + quad);
    dir.write("hot.mtl", "newmtl Material\nKd 0.5 0.5 0.5\nKe 1e300 1 1\n");
    CHECK_THROWS_WITH(parse_scene(scene_with(R"({"mesh": "hot.obj"})"), "s.json", dir.path.string()),
                      Contains("hot.obj: material 'Material': emission 1e+300 is too large (at most 1e+15)"));
}

TEST_CASE("MTL: Blender's Ks is its Principled specular, a dielectric's, no lobe, and Ns 0 is Lambertian", "[scenes][obj]") {
    // As Blender 3.6 writes every default material (Principled: specular 0.5, roughness 0.5).
    const std::string blender = "# Blender 3.6.0 MTL File: 'None'\n# www.blender.org\n\nnewmtl Material\nNs 250.000000\n"
                                "Ka 1.000000 1.000000 1.000000\nKd 0.800000 0.800000 0.800000\nKs 0.500000 0.500000 0.500000\n"
                                "Ke 0.000000 0.000000 0.000000\nNi 1.450000\nd 1.000000\nillum 2\n";
    TempDir dir;
    dir.write("a.obj", "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nusemtl Material\nf 1 3 2\n");
    dir.write("a.mtl", blender);
    const Scene scene = parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string());
    REQUIRE(scene.materials.size() == 1);
    CHECK_FALSE(scene.materials[0].glossy());  // as a glTF dielectric: the scene stays diffuse
    CHECK(scene.materials[0].albedo.isApprox(Rgb::Constant(0.8)));
    CHECK(scene.warnings.empty());
    // Another program's Ks is the lobe itself.
    std::string other = blender;
    other.replace(2, 7, "Maya   ");
    dir.write("a.mtl", other);
    const Scene plain = parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string());
    CHECK((plain.materials[0].albedo + plain.materials[0].specular).maxCoeff() == Approx(0.99));  // 0.8 + 0.5, scaled
    CHECK(plain.materials[0].exponent == 250.0);
    // A lobe of exponent 0 (MeshLab writes Ns 0) reflects as a Lambertian surface: albedo.
    dir.write("a.mtl", "newmtl Material\nKd 0.3 0.3 0.3\nKs 0.2 0.1 0\nNs 0\nillum 2\n");
    const Scene lambert = parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string());
    CHECK_FALSE(lambert.materials[0].glossy());
    CHECK(lambert.materials[0].albedo.isApprox(Rgb(0.5, 0.4, 0.3)));
}

TEST_CASE("OBJ + MTL: what is read otherwise is a warning, what cannot be is one line", "[scenes][obj][errors]") {
    TempDir dir;
    dir.write("room.obj", kObj);
    dir.write("room.mtl", std::string(kMtl) + "newmtl unused\nKd 0.9 0.9 0.9\nKs 0.5 0.5 0.5\n");
    // Kd + Ks past 1, a texture, an illum of glass.
    dir.write("warm.obj", std::string("mtllib warm.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl a\nf 1 3 2\n"));
    dir.write("warm.mtl", "newmtl a\nKd 0.8 0.5 0.5\nKs 0.4 0.1 0.1\nNs 10\nillum 7\nmap_Kd a.png\n");
    const Scene warm = parse_scene(scene_with(R"({"mesh": "warm.obj"}, {"mesh": "room.obj"})"), "s.json", dir.path.string());
    const Material& a = warm.materials[static_cast<std::size_t>(warm.find_material("a"))];
    CHECK((a.albedo + a.specular).maxCoeff() == Approx(0.99));
    REQUIRE(warm.warnings.size() == 3);
    CHECK_THAT(warm.warnings[0], Contains("warm.mtl: material 'a': illum 7"));
    CHECK_THAT(warm.warnings[1], Contains("its texture a.png is not read"));
    CHECK_THAT(warm.warnings[2], Contains("Kd + Ks = 1.2 in channel r: both scaled by 0.825"));
    auto fails = [&](const std::string& obj, const std::string& mtl, const std::string& needle) {
        dir.write("bad.obj", obj);
        dir.write("bad.mtl", mtl);
        INFO(obj << " / " << mtl);
        CHECK_THROWS_WITH(parse_scene(scene_with(R"({"mesh": "bad.obj"})"), "s.json", dir.path.string()),
                          Contains("objects[0]") && Contains(needle));
    };
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 0 1\n";
    dir.write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 0 1\n3 0 2 1\n");
    CHECK_THROWS_WITH(parse_scene(scene_with(R"({"mesh": "bad.ply"})"), "s.json", dir.path.string()),
                      Contains("objects[0].mesh: bad.ply: has no \"material\", and a .ply file names none"));
    fails("mtllib bad.mtl\n" + tri + "usemtl y\nf 1 3 2\n", "newmtl y\nKd 1 x 1\n", "bad.mtl: line 2");
    std::filesystem::create_directory(dir.path / "dir.mtl");
    fails("mtllib dir.mtl\n" + tri + "usemtl y\nf 1 3 2\n", "", "dir.mtl");
}

TEST_CASE("OBJ + MTL as assets come: a material file or name missing is 0.8 grey, with a warning", "[scenes][obj]") {
    // As Blender imports them: a missing MTL file, a name it does not define and faces
    // before the first usemtl are its default grey, and the run says which.
    TempDir dir;
    const auto load = [&](const std::string& obj, const std::string& mtl = "", const std::string& materials = "") {
        dir.write("a.obj", obj);
        if (!mtl.empty()) dir.write("a.mtl", mtl);
        return parse_scene(scene_with(R"({"mesh": "a.obj"})", materials), "s.json", dir.path.string());
    };
    const auto albedo = [](const Scene& s, const std::string& name) {
        const int m = s.find_material(name);
        return m < 0 ? Rgb(Rgb::Constant(-1)) : s.materials[static_cast<std::size_t>(m)].albedo;
    };
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\n";
    const Scene missing = load("mtllib missing.mtl\n" + tri + "usemtl y\nf 1 3 2\nusemtl z\nf 2 3 4\n");
    CHECK(albedo(missing, "y").isApprox(Rgb::Constant(0.8)));
    CHECK(albedo(missing, "z").isApprox(Rgb::Constant(0.8)));
    REQUIRE(missing.warnings.size() == 2);
    CHECK(missing.warnings[0] == "a.obj: mtllib missing.mtl: no such file; the materials it would define are 0.8 grey");
    CHECK(missing.warnings[1] == "a.obj: usemtl 'y' (line 6), 'z' (line 8): defined in no material file (mtllib "
                                 "missing.mtl) and not in the scene's \"materials\", so 0.8 grey; -D "
                                 "'materials.y={\"albedo\": [r, g, b]}' or the scene's \"materials\" defines one");
    // The scene's own material of that name is the material, as always: no warning for it.
    const Scene own = load("mtllib missing.mtl\n" + tri + "usemtl y\nf 1 3 2\n", "", R"("y": {"albedo": [0.1, 0.2, 0.3]})");
    CHECK(albedo(own, "y").isApprox(Rgb(0.1, 0.2, 0.3)));
    CHECK(own.warnings.size() == 1);
    // A name the file does not define; no mtllib at all.
    const Scene undefined = load("mtllib a.mtl\n" + tri + "usemtl y\nf 1 3 2\nusemtl x\nf 2 3 4\n", "newmtl x\nKd 0.2 0.2 0.2\n");
    CHECK(albedo(undefined, "y").isApprox(Rgb::Constant(0.8)));
    CHECK(albedo(undefined, "x").isApprox(Rgb::Constant(0.2)));
    REQUIRE(undefined.warnings.size() == 1);
    CHECK_THAT(undefined.warnings[0], StartsWith("a.obj: usemtl 'y' (line 6): defined in no material file (mtllib a.mtl)"));
    const Scene none = load(tri + "usemtl y\nf 1 3 2\n");
    REQUIRE(none.warnings.size() == 1);
    CHECK_THAT(none.warnings[0], Contains("(the mesh has no mtllib)"));
    // Many: four named, the rest counted.
    std::string many = tri;
    for (int k = 0; k < 6; ++k) many += "usemtl m" + std::to_string(k) + "\nf 1 3 2\n";
    const Scene six = load(many);
    REQUIRE(six.warnings.size() == 1);
    CHECK_THAT(six.warnings[0], Contains("usemtl 'm0' (line 5), 'm1' (line 7), 'm2' (line 9), 'm3' (line 11) and 2 more:"));
    // Faces before the first usemtl (Blender writes an object without a material so):
    // the material "default", which the scene may define.
    const Scene before = load("mtllib a.mtl\n" + tri + "f 1 3 2\nusemtl x\nf 2 3 4\n");
    CHECK(albedo(before, "default").isApprox(Rgb::Constant(0.8)));
    CHECK(albedo(before, "x").isApprox(Rgb::Constant(0.2)));
    REQUIRE(before.warnings.size() == 1);
    CHECK(before.warnings[0] == "a.obj: 1 face comes before the first usemtl: material 'default', 0.8 grey (the scene's "
                                "\"materials\" or -D 'materials.default={...}' defines it)");
    // No usemtl at all: every face is "default"; the MTL's "default" where it has one,
    // the same material as the usemtl of that name.
    const Scene none_named = load("mtllib a.mtl\n" + tri + "f 1 3 2\n");
    CHECK(albedo(none_named, "default").isApprox(Rgb::Constant(0.8)));
    REQUIRE(none_named.warnings.size() == 1);
    CHECK_THAT(none_named.warnings[0], StartsWith("a.obj: its faces name no material (no usemtl): material 'default', 0.8 grey"));
    dir.write("a.mtl", "newmtl x\nKd 0.2 0.2 0.2\nnewmtl default\nKd 0.3 0.3 0.3\n");
    const Scene defined_default = load("mtllib a.mtl\n" + tri + "f 1 3 2\nusemtl default\nf 2 3 4\n");
    CHECK(defined_default.materials.size() == 1);
    CHECK(albedo(defined_default, "default").isApprox(Rgb::Constant(0.3)));
    REQUIRE(defined_default.warnings.size() == 1);
    CHECK(defined_default.warnings[0] == "a.obj: 1 face comes before the first usemtl: material 'default' (the scene's "
                                         "\"materials\" or -D 'materials.default={...}' defines it)");
    dir.write("a.mtl", "newmtl x\nKd 0.2 0.2 0.2\n");
    const Scene set = load("mtllib a.mtl\n" + tri + "f 1 3 2\nusemtl x\nf 2 3 4\n", "", R"("default": {"albedo": [0.5, 0.5, 0.5]})");
    CHECK(albedo(set, "default").isApprox(Rgb::Constant(0.5)));
    CHECK(set.warnings.empty());
    // A library named by the exporter's folder is the file of its name beside the OBJ.
    const Scene windows = load("mtllib C:\\Users\\me\\a.mtl\n" + tri + "usemtl x\nf 1 3 2\n");
    CHECK(albedo(windows, "x").isApprox(Rgb::Constant(0.2)));
    CHECK(windows.warnings.empty());
    CHECK(std::find(windows.files.begin(), windows.files.end(), dir.path.string() + "/a.mtl") != windows.files.end());
    const Scene elsewhere = load("mtllib C:\\Users\\me\\b.mtl\n" + tri + "usemtl x\nf 1 3 2\n");
    REQUIRE(elsewhere.warnings.size() == 2);
    CHECK(elsewhere.warnings[0] == "a.obj: mtllib C:/Users/me/b.mtl: no such file, nor one of its name beside the mesh; "
                                   "the materials it would define are 0.8 grey");
}

TEST_CASE("OBJ: a backslash at a line's end goes on in the next", "[scenes][obj]") {
    TempDir dir;
    dir.write("a.obj", "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 \\\n 1\nusemtl x\nf 1 3 \\  \r\n 4 2\nf 1 9\n");
    dir.write("a.mtl", "newmtl x\n");
    // Errors name the line the statement begins on.
    CHECK_THROWS_WITH(parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string()),
                      Contains("a.obj: line 10: face references vertex 9"));
    // A comment's backslash is its own: the statement after it stays one.
    dir.write("a.obj", "mtllib a.mtl\n# C:\\models\\\nv 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 \\\n 1\nusemtl x\nf 1 3 \\  \r\n 4 2\n");
    const Scene scene = parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string());
    CHECK(scene.patch_count() == 2);  // the quad 1 3 4 2, its fourth vertex (1, 0, 1)
    CHECK(scene.total_area() == Approx(1.0));
    // A comment that ends in a backslash (a folder) joins nothing; a statement's last
    // backslash in the file joins nothing either.
    dir.write("a.obj", "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1 # from C:\\models\\\nv 1 0 1\nusemtl x\nf 1 3 4 2 \\");
    CHECK(parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string()).total_area() == Approx(1.0));
    // A name's backslash is its own: "mtllib sub\" names a folder, not the next line.
    dir.write("a.obj", "mtllib a.mtl\nusemtl x\\\nv 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n");
    CHECK(parse_scene(scene_with(R"({"mesh": "a.obj"})"), "s.json", dir.path.string()).total_area() == Approx(0.5));
}

TEST_CASE("an OBJ file alone is a scene: framed from +z, its patch size from its size", "[scenes][obj]") {
    TempDir dir;
    dir.write("room.obj", kObj);
    dir.write("room.mtl", kMtl);
    const std::string path = dir.path.string() + "/room.obj";
    const Scene scene = load_scene(path);
    CHECK(scene.camera.target.isApprox(Vec3(1, 0.5, 0.5)));
    // A loose vertex and a wire edge (Blender writes them) are not framed.
    dir.write("loose.obj", std::string(kObj) + "o Loose\nv 1000 1000 1000\nl 11 1\n");
    const Scene loose = load_scene(dir.path.string() + "/loose.obj");
    CHECK(loose.camera.target.isApprox(scene.camera.target));
    CHECK(loose.camera.eye.isApprox(scene.camera.eye));
    CHECK(scene.camera.eye.x() == Approx(1.0));
    CHECK(scene.camera.eye.z() > 1.0);
    CHECK(scene.patch_count() > 6);  // refined to 2/25
    CHECK(scene.files.front() == path);
    // A flat horizontal model, seen edge-on from +z: from 45 degrees above the side it
    // faces instead (below it where it faces down).
    dir.write("ground.obj", "v -1 0 -1\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nf 1 2 3 4\n");  // faces +y
    const Scene ground = load_scene(dir.path.string() + "/ground.obj");
    const Vec3 view = (ground.camera.target - ground.camera.eye).normalized();
    CHECK(view.isApprox(Vec3(0, -1, -1).normalized()));
    CHECK(ground.patch_list()[0].normal.dot(ground.camera.eye - ground.patch_list()[0].centroid) > 0.0);
    dir.write("ceiling.obj", "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3 4\n");  // faces -y
    const Scene ceiling = load_scene(dir.path.string() + "/ceiling.obj");
    CHECK((ceiling.camera.target - ceiling.camera.eye).normalized().isApprox(Vec3(0, 1, -1).normalized()));
    // Overrides apply to its document: the camera, a material replaced.
    const Scene moved = load_scene(path, {{"camera.eye", "[1, 5, 5]"}, {"materials.lamp", R"({"albedo": [0, 0, 0], "emission": [1, 1, 1]})"}});
    CHECK(moved.camera.eye.isApprox(Vec3(1, 5, 5)));
    CHECK(moved.materials[static_cast<std::size_t>(moved.find_material("lamp"))].emission.isApprox(Rgb::Constant(1)));
    // One value of an MTL's material: that value changes, the rest as the MTL has it.
    const Scene brighter = load_scene(path, {{"materials.lamp.emission", "[10, 10, 10]"}, {"materials.red.albedo", "[0.5, 0, 0]"}});
    const auto material = [](const Scene& s, const std::string& name) -> const Material& {
        return s.materials[static_cast<std::size_t>(s.find_material(name))];
    };
    CHECK(material(brighter, "lamp").emission.isApprox(Rgb::Constant(10)));
    CHECK(material(brighter, "lamp").albedo.isApprox(Rgb::Zero()));
    CHECK(material(brighter, "red").albedo.isApprox(Rgb(0.5, 0, 0)));
    CHECK(material(brighter, "green").specular.isApprox(Rgb::Constant(0.2)));
    CHECK(brighter.materials.size() == scene.materials.size());
    // One element of a brought value: the value's other elements as the MTL has them.
    const Scene redder = load_scene(path, {{"materials.red.albedo[1]", "0.25"}, {"materials[\"lamp\"].emission[0]", "7"}});
    CHECK(material(redder, "red").albedo[1] == 0.25);
    CHECK(material(redder, "red").albedo[0] == material(scene, "red").albedo[0]);
    CHECK(material(redder, "red").albedo[2] == material(scene, "red").albedo[2]);
    CHECK(material(redder, "lamp").emission[0] == 7.0);
    CHECK(material(redder, "lamp").emission[1] == material(scene, "lamp").emission[1]);
    CHECK_THROWS_WITH(load_scene(path, {{"materials.red.albedo[3]", "0.5"}}),
                      Contains("materials.red.albedo[3]: no such element in the values the mesh brings "
                               "(-D materials.red.albedo[3]=0.5)"));
    // A value that leaves it out of range is refused, naming the setting.
    CHECK_THROWS_WITH(load_scene(path, {{"materials.green.albedo", "[0.9, 0.9, 0.9]"}}),
                      Contains("materials.green: albedo + specular = 1.1 in channel r") &&
                          Contains("-D materials.green.albedo=[0.9, 0.9, 0.9]"));
    // A value of a material no mesh brings, without an albedo, is no material.
    CHECK_THROWS_WITH(load_scene(path, {{"materials.lmap.emission", "[1, 1, 1]"}}),
                      Contains("materials.lmap: no material 'lmap' for -D to change a value of: the scene's own materials "
                               "and its meshes' have none of that name (a new material needs its albedo)"));
    // A new material of its albedo alone is a material.
    CHECK(load_scene(path, {{"materials.grey.albedo", "[0.5, 0.5, 0.5]"}}).find_material("grey") >= 0);
    dir.write("m.ply", "ply\n");
    CHECK_THROWS_WITH(load_scene(dir.path.string() + "/m.ply"), Contains("m.ply") && Contains("has no materials"));
    // Alone, its errors and its parts are its own: no objects[0] of a scene file the
    // user never wrote, the file as the user named it.
    CHECK_THAT(scene.object_names.front(), StartsWith("room.obj: "));
    dir.write("grey.obj", "mtllib room.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl lite\nf 1 3 2\n");
    const Scene grey = load_scene(dir.path.string() + "/grey.obj");
    REQUIRE_FALSE(grey.warnings.empty());
    CHECK_THAT(grey.warnings[0], StartsWith("grey.obj: usemtl 'lite' (line 5): defined in no material file (mtllib room.mtl)"));
    // A model so large that the camera framing it would lie past 1e15: the model is the
    // reason, not a camera the user never set.
    dir.write("far.obj", "mtllib room.mtl\nusemtl red\nv 0 0 0\nv 9e14 0 0\nv 0 9e14 0\nf 1 2 3\n");
    CHECK_THROWS_WITH(load_scene(dir.path.string() + "/far.obj"),
                      Contains("far.obj: the camera placed to frame it (") && Contains("would lie past 1e15"));
    dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 4\n");
    CHECK_THROWS_WITH(load_scene(dir.path.string() + "/bad.obj"),
                      dir.path.string() + "/bad.obj: line 4: face references vertex 4, but only 3 vertices are "
                                          "defined before it");
}

TEST_CASE("MTL: a PNG map_Kd on faces without vt is the albedo by its mean linear colour", "[scenes][obj]") {
    TempDir dir;
    raybundle::render::Image texture(4, 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            float* p = texture.at(x, y);
            p[0] = x < 2 ? 0.8f : 0.2f;  // mean 0.5
            p[1] = 0.25f;
            p[2] = 0.1f;
        }
    raybundle::render::write_png((dir.path / "wood.png").string(), texture, 0.0);
    dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl wood\nf 1 3 2\n");
    dir.write("t.mtl", "newmtl wood\nKd 0.9 0.9 0.9\nmap_Kd wood.png\n");
    const Scene scene = parse_scene(scene_with(R"({"mesh": "t.obj"})"), "s.json", dir.path.string());
    const Rgb albedo = scene.materials[0].albedo;
    CHECK(albedo[0] == Approx(0.5).epsilon(0.01));  // 8-bit sRGB: within 1 %
    CHECK(albedo[1] == Approx(0.25).epsilon(0.01));
    CHECK(albedo[2] == Approx(0.1).epsilon(0.02));
    REQUIRE(scene.warnings.size() == 1);
    CHECK_THAT(scene.warnings[0], Contains("its texture wood.png is read as its mean colour"));
    CHECK(std::find(scene.files.begin(), scene.files.end(), (dir.path / "wood.png").string()) != scene.files.end());
}

namespace {

// A JPEG of one colour (quality 100), as a camera or a paint program writes one.
void write_jpeg(const std::string& path, int width, int height, std::array<unsigned char, 3> rgb) {
    jpeg_compress_struct jpeg{};
    jpeg_error_mgr errors{};
    jpeg.err = jpeg_std_error(&errors);
    jpeg_create_compress(&jpeg);
    unsigned char* bytes = nullptr;
    unsigned long size = 0;
    jpeg_mem_dest(&jpeg, &bytes, &size);
    jpeg.image_width = static_cast<JDIMENSION>(width);
    jpeg.image_height = static_cast<JDIMENSION>(height);
    jpeg.input_components = 3;
    jpeg.in_color_space = JCS_RGB;
    jpeg_set_defaults(&jpeg);
    jpeg_set_quality(&jpeg, 100, TRUE);
    jpeg_start_compress(&jpeg, TRUE);
    std::vector<unsigned char> row;
    for (int x = 0; x < width; ++x) row.insert(row.end(), rgb.begin(), rgb.end());
    while (jpeg.next_scanline < jpeg.image_height) {
        JSAMPROW rows[1] = {row.data()};
        jpeg_write_scanlines(&jpeg, rows, 1);
    }
    jpeg_finish_compress(&jpeg);
    jpeg_destroy_compress(&jpeg);
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes), static_cast<std::streamsize>(size));
    std::free(bytes);
}

}  // namespace

TEST_CASE("MTL: map_Kd as exporters write it, and a texture not read says why", "[scenes][obj]") {
    TempDir dir;
    // 2 x 1 texels, RGBA: red of alpha 0 and green of alpha 128. Alpha is left out, not
    // mixed onto black: the mean is (0.5, 0.5, 0).
    const unsigned char rgba[8] = {255, 0, 0, 0, 0, 255, 0, 128};
    std::filesystem::create_directories(dir.path / "my maps");
    dir.write("my maps/cut out.png", raybundle::test::png_bytes(2, 1, rgba));
    dir.write("photo.jpg", std::string("\xFF\xD8\xFF\xE0\x00\x10JFIF", 10));
    dir.write("broken.png", std::string("\x89PNG\r\n\x1A\n\x00\x00", 10));
    dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 0 1\nusemtl m\nf 1 3 2\n");
    auto albedo_with = [&](const std::string& map_kd, std::string& warning) {
        dir.write("t.mtl", "newmtl m\nKd 0.2 0.2 0.2\nmap_Kd " + map_kd + "\n");
        const Scene scene = parse_scene(scene_with(R"({"mesh": "t.obj"})"), "s.json", dir.path.string());
        REQUIRE(scene.warnings.size() == 1);
        warning = scene.warnings[0];
        return scene.materials[0].albedo;
    };
    std::string warning;
    // Options before the name, a name with spaces, and Windows' separators.
    for (const std::string map_kd : {"my maps/cut out.png", "-s 2 2 1 -o 0.5 0 -bm 1 -clamp on my maps/cut out.png",
                                     "-blendu off my maps\\cut out.png", "-clamp my maps/cut out.png"}) {
        INFO(map_kd);
        const Rgb a = albedo_with(map_kd, warning);
        CHECK(a[0] == Approx(0.5).epsilon(0.01));
        CHECK(a[1] == Approx(0.5).epsilon(0.01));
        CHECK(a[2] == 0.0);
        CHECK_THAT(warning, Contains("its texture my maps/cut out.png is read as its mean colour"));
    }
    // An option this reader does not know: the last word, where the whole is no file.
    std::filesystem::copy_file(dir.path / "my maps" / "cut out.png", dir.path / "wood.png");
    CHECK(albedo_with("-gamma 2.2 wood.png", warning)[0] == Approx(0.5).epsilon(0.01));
    CHECK_THAT(warning, Contains("its texture wood.png is read as its mean colour"));
    // A path of the exporter's machine: the file of that name beside the MTL.
    CHECK(albedo_with("C:\\Users\\bob\\Desktop\\textures\\wood.png", warning)[0] == Approx(0.5).epsilon(0.01));
    CHECK_THAT(warning, Contains("its texture wood.png is read as its mean colour"));
    CHECK(albedo_with("photo.jpg", warning)[0] == Approx(0.2));
    CHECK_THAT(warning, Contains("its texture photo.jpg is not read (a JPEG libjpeg cannot read: "));
    CHECK_THAT(warning, Contains("its Kd 0.2 0.2 0.2 is the colour"));
    // A JPEG (the commonest texture): its mean, sRGB decoded, as a PNG's.
    write_jpeg((dir.path / "wall.jpg").string(), 16, 8, {200, 100, 50});
    const Rgb wall = albedo_with("wall.jpg", warning);
    CHECK(wall[0] == Approx(std::pow((200 / 255.0 + 0.055) / 1.055, 2.4)).epsilon(0.02));
    CHECK(wall[1] == Approx(std::pow((100 / 255.0 + 0.055) / 1.055, 2.4)).epsilon(0.02));
    CHECK(wall[2] == Approx(std::pow((50 / 255.0 + 0.055) / 1.055, 2.4)).epsilon(0.03));
    CHECK_THAT(warning, Contains("its texture wall.jpg is read as its mean colour"));
    // Cut short, libjpeg fills the rest with grey: no mean of its own colours.
    write_jpeg((dir.path / "big.jpg").string(), 256, 256, {20, 200, 20});
    const auto whole = std::filesystem::file_size(dir.path / "big.jpg");
    std::filesystem::resize_file(dir.path / "big.jpg", whole * 9 / 10);  // inside its scan
    CHECK(albedo_with("big.jpg", warning)[0] == Approx(0.2));
    CHECK_THAT(warning, Contains("its texture big.jpg is not read (a JPEG libjpeg reads only in part (cut short?))"));
    albedo_with("broken.png", warning);
    CHECK_THAT(warning, Contains("its texture broken.png is not read (a PNG libpng cannot read: "));
    albedo_with("gone.png", warning);
    CHECK_THAT(warning, Contains("its texture gone.png is not read (no such file beside t.mtl)"));
}
