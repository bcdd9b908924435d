// The mesh readers (OBJ, PLY ASCII and binary, OFF ASCII and binary) and the scene
// file's JSON: good files in every encoding give the same mesh; malformed ones, among
// them the inputs a mutation fuzzer found crashing or hanging OpenMesh's readers, give
// one clear SceneError line naming the file and the place, without allocating for
// counts the file cannot hold.
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "scenes/mesh_file.h"

#include "temp_dir.h"

#include <catch2/catch.hpp>

#include <sys/stat.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace raybundle::scenes;
using Catch::Matchers::Contains;

using raybundle::test::TempDir;

namespace {

// Bytes of a value in little- or big-endian order.
template <class T>
std::string bytes(T value, bool big_endian) {
    std::string b(sizeof(T), '\0');
    std::memcpy(b.data(), &value, sizeof(T));
    const std::uint16_t one = 1;
    const bool host_little = *reinterpret_cast<const unsigned char*>(&one) == 1;
    if (big_endian == host_little) std::reverse(b.begin(), b.end());
    return b;
}

// The unit square as two triangles (a quad face split into a fan), with +z normals.
const std::vector<std::array<double, 3>> kSquare = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};

std::string ply_header(const std::string& format, bool normals, const std::string& extra_element = "") {
    return "ply\nformat " + format + " 1.0\ncomment a square\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\n" +
           (normals ? "property float nx\nproperty float ny\nproperty float nz\n" : "") +
           "property uchar red\n" + extra_element + "element face 1\nproperty list uchar int vertex_indices\n"
           "property int flags\nend_header\n";
}

std::string binary_ply(bool big_endian) {
    std::string s = ply_header(big_endian ? "binary_big_endian" : "binary_little_endian", true,
                               "element edge 1\nproperty list uchar short ends\n");
    for (const auto& v : kSquare) {
        for (double c : v) s += bytes(static_cast<float>(c), big_endian);
        for (float n : {0.0f, 0.0f, 2.0f}) s += bytes(n, big_endian);
        s += bytes(std::uint8_t{200}, big_endian);
    }
    s += bytes(std::uint8_t{2}, big_endian) + bytes(std::int16_t{0}, big_endian) + bytes(std::int16_t{1}, big_endian);
    s += bytes(std::uint8_t{4}, big_endian);
    for (int i : {0, 1, 2, 3}) s += bytes(std::int32_t{i}, big_endian);
    s += bytes(std::int32_t{7}, big_endian);
    return s;
}

void check_square(const MeshData& m, bool normals) {
    REQUIRE(m.vertices.size() == 4);
    for (std::size_t i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k) CHECK(m.vertices[i][k] == kSquare[i][k]);
    REQUIRE(m.triangles.size() == 2);
    CHECK(m.triangles[0] == std::array<int, 3>{0, 1, 2});
    CHECK(m.triangles[1] == std::array<int, 3>{0, 2, 3});
    REQUIRE(m.normals.size() == (normals ? 2u : 0u));
    for (const auto& corner : m.normals)
        for (const auto& n : corner) CHECK(n.z() == Approx(1.0));  // normalised
}

}  // namespace

TEST_CASE("every mesh encoding reads the same square", "[scenes][mesh]") {
    TempDir dir;
    check_square(read_mesh_file(dir.write("a.ply", ply_header("ascii", true) +
                                                       "0 0 0 0 0 1 9\n1 0 0 0 0 1 9\n1 1 0 0 0 1 9\n0 1 0 0 0 1 9\n"
                                                       "4 0 1 2 3 5\n"),
                                "a.ply"),
                 true);
    check_square(read_mesh_file(dir.write("le.ply", binary_ply(false)), "le.ply"), true);
    check_square(read_mesh_file(dir.write("be.ply", binary_ply(true)), "be.ply"), true);
    check_square(read_mesh_file(dir.write("a.off", "OFF\n# a comment\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"),
                                "a.off"),
                 false);
    // Counts on the magic's line, CRLF line ends, per-vertex extras (COFF colours).
    check_square(read_mesh_file(dir.write("c.off", "COFF 4 1 0\r\n0 0 0 255 0 0 255\r\n1 0 0 255 0 0 255\r\n"
                                                   "1 1 0 1 1 1 1\r\n0 1 0 1 1 1 1\r\n4 0 1 2 3 0 0 0\r\n"),
                                "c.off"),
                 false);
    std::string off = "OFF BINARY\n";
    for (std::int32_t n : {4, 1, 0}) off += bytes(n, true);
    for (const auto& v : kSquare)
        for (double c : v) off += bytes(static_cast<float>(c), true);
    for (std::int32_t n : {4, 0, 1, 2, 3, 0}) off += bytes(n, true);
    check_square(read_mesh_file(dir.write("b.off", off), "b.off"), false);
    check_square(read_mesh_file(dir.write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"), "q.obj"), false);
}

TEST_CASE("malformed meshes: one line naming the file and the place, bounded work", "[scenes][mesh][errors]") {
    TempDir dir;
    auto fails_with = [&](const std::string& name, const std::string& content, const std::string& needle) {
        const std::string path = dir.write(name, content);
        INFO(name << ": " << needle);
        try {
            read_mesh_file(path, name);
            FAIL("no error");
        } catch (const SceneError& e) {
            const std::string what = e.what();
            CHECK_THAT(what, Contains(name + ": ") && Contains(needle));
            CHECK(what.find('\n') == std::string::npos);
        }
    };
    const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
    const std::string faces = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string tri = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

    SECTION("PLY headers") {
        // The fuzzer's crash in OpenMesh: a property before any element.
        fails_with("p.ply", "ply\nformat ascii 1.0\nproperty float x\nelement vertex 3\nend_header\n",
                   "header line 3: property before any element");
        // The fuzzer's endless loop: no end_header.
        fails_with("h.ply", "ply\nformat ascii 1.0\n", "header: no end_header line");
        fails_with("m.ply", "PLY\nformat ascii 1.0\nend_header\n", "not a PLY file");
        fails_with("f.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format 'binary_middle_endian'");
        fails_with("v.ply", "ply\nformat ascii 2.0\nend_header\n", "unknown version '2.0'");
        fails_with("nf.ply", "ply\nelement vertex 3\n" + xyz + faces + "end_header\n" + tri, "header: no format line");
        fails_with("t.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float128 x\nend_header\n",
                   "unknown property type 'float128'");
        fails_with("k.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz + "colour red\nend_header\n",
                   "unknown header keyword 'colour'");
        fails_with("lt.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz +
                                 "element face 1\nproperty list float int vertex_indices\nend_header\n" + tri,
                   "list count type 'float' is not an integer type");
        fails_with("nx.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" + faces +
                                 "end_header\n0 0\n1 0\n0 1\n3 0 1 2\n",
                   "the vertex element has no property z");
        fails_with("ni.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz +
                                 "element face 1\nproperty list uchar int corners\nend_header\n" + tri,
                   "the face element has no integer list vertex_indices");
        // Found by the fuzzer (scripts/fuzz.sh): an ASCII list count of 2e120 for a
        // uchar count type was converted to a long (undefined behaviour).
        fails_with("huge-count.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz +
                                         "element edge 1\nproperty list uchar short ends\n" + faces +
                                         "end_header\n0 0 0\n1 0 0\n0 1 0\n2.22222e+120 0 1\n3 0 1 2\n",
                   "edge 0: value '2.22222e+120' is outside its type's range (0 to 255)");
        fails_with("short-range.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz +
                                          "element face 1\nproperty list uchar short vertex_indices\nend_header\n"
                                          "0 0 0\n1 0 0\n0 1 0\n3 0 1 40000\n",
                   "face 0: value '40000' is outside its type's range (-32768 to 32767)");
        fails_with("nofaces.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz + "end_header\n0 0 0\n1 0 0\n0 1 0\n",
                   "the mesh has no faces");
    }
    SECTION("PLY counts the file cannot hold are refused before allocating") {
        for (const std::string count : {"2147483648", "-3", "inf", "1e9", "0x10", ""}) {
            fails_with("c.ply", "ply\nformat ascii 1.0\nelement vertex " + count + "\n" + xyz + faces + "end_header\n" + tri,
                       count.empty() ? "element needs a name and a count" : "element count '" + count + "' is not a count");
        }
        fails_with("big.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 2147483647\n" + xyz + faces +
                                  "end_header\n" + std::string(64, '\0'),
                   "vertex: file is truncated: header promises 2147483647 vertices, the 64 bytes after it hold at most 5");
        // A list claiming 255 corners in a file with 4 bytes left.
        std::string list = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" + xyz + faces + "end_header\n";
        for (int k = 0; k < 9; ++k) list += bytes(static_cast<float>(k % 2), false);
        list += bytes(std::uint8_t{255}, false) + bytes(std::int32_t{0}, false);
        fails_with("list.ply", list, "face 0: file is truncated: header promises 255 list items");
        fails_with("tb.ply", list.substr(0, list.size() - 10), "vertex: file is truncated");
    }
    SECTION("PLY data") {
        const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz + faces + "end_header\n";
        fails_with("short.ply", head + "0 0 0\n1 0 0\n0 1 0\n", "file is truncated");
        fails_with("range.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                   "face 0: references vertex 3, but the file has 3 vertices");
        fails_with("neg.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "face 0: references vertex -1");
        fails_with("two.ply", head + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0: face has 2 corners (at least 3 needed)");
        fails_with("word.ply", head + "0 0 zero\n1 0 0\n0 1 0\n3 0 1 2\n", "vertex 0: malformed value 'zero'");
        fails_with("inf.ply", head + "0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n", "vertex 1: value 'inf' is not finite");
        fails_with("half.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "face 0: value '1.5' is not a whole number");
        // An ASCII element is one line: a header whose count is not the file's is named
        // where the lines stop matching, with what the header says, not as a later face.
        const std::string quad = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
        const std::string two_faces = "element face 2\nproperty list uchar int vertex_indices\n";
        fails_with("more.ply", "ply\nformat ascii 1.0\nelement vertex 6\n" + xyz + two_faces + "end_header\n" + quad,
                   "vertex 4: its line holds more values than the header gives it (the header gives each vertex x, y, "
                   "z, and counts 6)");
        fails_with("fewer.ply", "ply\nformat ascii 1.0\nelement vertex 3\n" + xyz + two_faces + "end_header\n" + quad,
                   "face 0: its line holds more values than the header gives it (the header gives each face "
                   "vertex_indices (a list), and counts 2)");
        fails_with("gap.ply", head + "0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
                   "vertex 1: its line ends before its values do (the header gives each vertex x, y, z, and counts 3)");
        fails_with("long.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 3\n", "face 0: its line holds more values");
        // Line ends of any kind, spaces before them and no last one are read.
        const std::string crlf = "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\n"
                                 "property float z\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n"
                                 "end_header\r\n0 0 0 \r\n1 0 0\t\r\n0 1 0\r\n3 0 1 2";
        CHECK(read_mesh_file(dir.write("crlf.ply", crlf), "crlf.ply").vertices.size() == 3);
        std::string nan_ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n" + xyz + faces + "end_header\n";
        for (int k = 0; k < 9; ++k) nan_ply += bytes(k == 4 ? std::nanf("") : 0.0f, false);
        nan_ply += bytes(std::uint8_t{3}, false) + bytes(std::int32_t{0}, false) + bytes(std::int32_t{1}, false) +
                   bytes(std::int32_t{2}, false);
        fails_with("nan.ply", nan_ply, "vertex 1: coordinate (0, nan, 0) is not finite");
    }
    SECTION("OFF") {
        fails_with("m.off", "MOFF\n3 1 0\n" + tri, "not an OFF file ('MOFF'");
        fails_with("4.off", "4OFF\n3 1 0\n" + tri, "not an OFF file ('4OFF'");
        fails_with("c.off", "OFF\n", "missing vertex and face counts");
        for (const std::string count : {"2147483648", "-3", "inf"})
            fails_with("n.off", "OFF\n" + count + " 1 0\n" + tri, "header: vertex count '" + count + "' is not a count");
        fails_with("huge.off", "OFF\n2000000000 1 0\n" + tri,
                   "vertices: file is truncated: header promises 2000000000 vertices");
        fails_with("two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "face 0: face has 2 corners");
        fails_with("k.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n300000 0 1 2\n",
                   "face 0: file is truncated: header promises 300000 corners");
        fails_with("few.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "face 0: has fewer than the 4 indices");
        std::string bin = "OFF BINARY\n" + bytes(std::int32_t{1 << 30}, true) + bytes(std::int32_t{1}, true) +
                          bytes(std::int32_t{0}, true);
        fails_with("b.off", bin, "vertices: file is truncated: header promises 1073741824 vertices");
        fails_with("bt.off", "OFF BINARY\n" + bytes(std::int32_t{3}, true), "header: file is truncated");
    }
    SECTION("OBJ") {
        fails_with("two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3: face has 2 corners (at least 3 needed)");
        fails_with("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4: face references vertex -4");
        // A word that is not a number, in a coordinate or after them; w, vertex colours
        // and comments are fine.
        fails_with("x.obj", "v 0 0 0\nv 1 0 0.5x\nv 0 1 0\nf 1 2 3\n", "line 2: coordinate '0.5x' is not a number");
        fails_with("junk.obj", "v 0 0 0 junk\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                   "line 1: 'junk' after the vertex's coordinates is not a number");
        fails_with("vn.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1 up\nf 1//1 2//1 3//1\n",
                   "line 4: 'up' after the normal's coordinates is not a number");
        CHECK(read_mesh_file(dir.write("extra.obj", "v 0 0 0 1\nv 1 0 0 1 0.5 0.5\nv 0 1 0 # a corner\r\nf 1 2 3\n"),
                             "extra.obj").triangles.size() == 1);
        fails_with("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n",
                   "line 4: face corner '0': vertex index 0 (OBJ counts from 1, and back from -1)");
        fails_with("empty.obj", "", "the mesh has no faces");
        // A texture coordinate is checked like a vertex or a normal (it was not: issue 30).
        fails_with("vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
                   "line 5: face references texture coordinate 2, but only 1 texture coordinate is defined");
        fails_with("vt0.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/0/ 2/1 3/1\n",
                   "line 5: face corner '1/0/': texture coordinate index 0 (OBJ counts from 1");
        // A polygon of more corners than its crossing test can afford, refused at once.
        std::string big;
        for (int k = 0; k < 600; ++k)
            big += "v " + std::to_string(std::cos(0.01 * k)) + " " + std::to_string(std::sin(0.01 * k)) + " 0\n";
        big += "f";
        for (int k = 1; k <= 600; ++k) big += " " + std::to_string(k);
        fails_with("big.obj", big + "\n", "line 601: face has 600 corners, at most 512");
    }
    SECTION("OBJ: a UTF-8 byte order mark before the first line is skipped") {
        const std::string path = dir.write("bom.obj", "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        const auto mesh = read_mesh_file(path, "bom.obj");
        CHECK(mesh.vertices.size() == 3);
        CHECK(mesh.triangles.size() == 1);
    }
    SECTION("not a file of bytes") {
        fails_with("empty.ply", "", "not a PLY file");
        fails_with("empty.off", "", "header: empty file");
        fs::create_directory(dir.path / "d.obj");
        CHECK_THROWS_WITH(read_mesh_file((dir.path / "d.obj").string(), "d.obj"),
                          "d.obj: is a directory, not a mesh file");
        const std::string fifo = (dir.path / "f.ply").string();
        REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);  // opening it would block for ever
        CHECK_THROWS_WITH(read_mesh_file(fifo, "f.ply"),
                          "f.ply: is not a regular file (a FIFO, a socket or a device), not a mesh file");
        if (fs::exists("/dev/zero")) {  // endless zeros, behind a mesh's name
            fs::create_symlink("/dev/zero", dir.path / "zero.off");
            CHECK_THROWS_WITH(read_mesh_file((dir.path / "zero.off").string(), "zero.off"),
                              Contains("zero.off: is not a regular file"));
        }
        CHECK_THROWS_WITH(read_mesh_file(dir.write("x.stl", "solid"), "x.stl"),
                          "x.stl: unknown mesh format '.stl' (known: .obj, .ply, .off, .gltf, .glb)");
        CHECK_THROWS_WITH(load_scene(fifo), Contains("f.ply: is not a regular file") && Contains("scene file"));
    }
}

TEST_CASE("scene JSON: nesting bounded, keys once, integers of any size", "[scenes][errors]") {
    auto fails_with = [](const std::string& text, const std::string& needle) {
        INFO(text.substr(0, 200));
        try {
            parse_scene(text, "s.json", ".");
            FAIL("no error");
        } catch (const SceneError& e) {
            const std::string what = e.what();
            CHECK_THAT(what, Contains("s.json") && Contains(needle));
            CHECK(what.find('\n') == std::string::npos);
            CHECK(what.size() < 300);
        }
    };
    // 60,000 nested arrays overflowed the stack; now refused at depth 64 while reading.
    fails_with("{\"objects\": " + std::string(60000, '[') + std::string(60000, ']') + "}", "nested more than 64 deep");
    fails_with(R"({"camera": {"eye": [0,0,5], "target": [0,0,0], "eye": [1,1,1]}})", "camera.eye: key given twice");
    fails_with(R"({"materials": {"w": {"albedo": [0.5,0.5,0.5]}}, "objects": [{"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]],
               "material": "w", "material": "w"}]})",
               "objects[0].material: key given twice");
    // The smallest long long: its absolute value overflowed (UB) in the range check.
    fails_with(R"({"camera": {"eye": [0,0,5], "target": [0,0,0], "width": -9223372036854775808}})",
               "camera.width: value -9223372036854775808 is out of range");
    // Long values are cut in the message: an array, a number too large for a double.
    std::string ones = "1";
    for (int k = 0; k < 2000; ++k) ones += ",1";
    fails_with(R"({"camera": {"eye": [)" + ones + "]}}", "camera.eye: expected [x, y, z], got [1,1,1,");
    fails_with(R"({"camera": {"eye": [)" + std::string(5000, '1') + "]}}", "...");
    // Magnitudes whose products overflow: coordinates, intensities.
    fails_with(R"({"camera": {"eye": [0,0,5], "target": [0,0,1e200]}})",
               "camera.target: value 1e+200 is too large (at most 1e+15 in magnitude)");
    fails_with(R"({"camera": {"eye": [0,0,5], "target": [0,0,0]}, "materials": {"w": {"albedo": [0.5,0.5,0.5]}},
               "objects": [{"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "w"}],
               "point_lights": [{"position": [0,0,1], "intensity": [1e308, 1, 1]}]})",
               "point_lights[0].intensity: value 1e+308 is too large");
    // A sliver of little area but a long edge (its area alone asks for 1.25e7 patches):
    // the patch limit counts its length.
    fails_with(R"({"camera": {"eye": [0,0,5], "target": [0,0,0]}, "materials": {"w": {"albedo": [0.5,0.5,0.5]}},
               "objects": [{"triangle": [[0,0,0],[1e5,0,0],[0,1e-3,0]], "material": "w"}], "patch_size": 0.004})",
               "patch_size: 0.004 would make about 25,000,000 patches (limit ");  // 20,000,000, or less on a small machine
    // A byte-order mark is read past (editors on Windows write one).
    const Scene s = parse_scene("\xEF\xBB\xBF" R"({"camera": {"eye": [0,0,5], "target": [0,0,0]},
        "materials": {"w": {"albedo": [0.5,0.5,0.5]}}, "objects": [{"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "w"}]})",
                                "s.json", ".");
    CHECK(s.patch_count() >= 2);
}

namespace {

// Twice the area of each triangle, its normal's z, over a mesh in the z = 0 plane (or
// any plane: the normal along `up`).
struct Cut {
    double area = 0.0;
    bool folded = false;  // a triangle turned against the polygon
};
Cut cut_of(const MeshData& m, const Vec3& up) {
    Cut c;
    for (const auto& t : m.triangles) {
        const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
        c.area += n.norm() / 2.0;
        c.folded = c.folded || n.dot(up) < 0.0;
    }
    return c;
}

}  // namespace

TEST_CASE("polygons: convex fanned, concave cut into ears, bent or crossing ones refused", "[scenes][mesh]") {
    TempDir dir;
    auto read = [&](const std::string& name, const std::string& content) {
        return read_mesh_file(dir.write(name, content), name);
    };
    auto fails_with = [&](const std::string& name, const std::string& content, const std::string& needle) {
        INFO(name);
        REQUIRE_THROWS_WITH(read(name, content), Contains(name + ": ") && Contains(needle));
    };
    SECTION("a convex polygon is the fan from its first corner, as before") {
        const MeshData m = read("pentagon.obj", "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nf 1 2 3 4 5\n");
        REQUIRE(m.triangles.size() == 3);
        CHECK(m.triangles[0] == std::array<int, 3>{0, 1, 2});
        CHECK(m.triangles[2] == std::array<int, 3>{0, 3, 4});
    }
    SECTION("a concave polygon whose fan would fold: ears, no fold, its exact area") {
        // An arrowhead from a back corner (the fan's first triangle would turn over at
        // the notch, corner 1) and an L-shaped hexagon from a corner whose fan would leave
        // the polygon.
        const MeshData arrow = read("arrow.obj", "v 2 -1 0\nv 1 0.2 0\nv 2 1 0\nv 0 0 0\nf 1 2 3 4\n");
        const Cut a = cut_of(arrow, Vec3::UnitZ());
        CHECK_FALSE(a.folded);
        CHECK(a.area == Approx(1.0));
        const MeshData ell =
            read("ell.off", "OFF\n6 1 0\n0 2 0\n0 0 0\n2 0 0\n2 1 0\n1 1 0\n1 2 0\n6 0 1 2 3 4 5\n");
        const Cut l = cut_of(ell, Vec3::UnitZ());
        CHECK(ell.triangles.size() == 4);
        CHECK_FALSE(l.folded);
        CHECK(l.area == Approx(3.0));
    }
    SECTION("the corner normals follow the ears") {
        const std::string ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                                "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "2 -1 0 0 -0.1 1\n1 0.2 0 0.2 0 1\n2 1 0 0 0.1 1\n0 0 0 0 0 1\n4 0 1 2 3\n";
        const MeshData m = read("arrow.ply", ply);
        REQUIRE(m.normals.size() == m.triangles.size());
        for (std::size_t t = 0; t < m.triangles.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const int v = m.triangles[t][k];
                const Vec3 expected = v == 0 ? Vec3(0, -0.1, 1) : v == 1 ? Vec3(0.2, 0, 1) : v == 2 ? Vec3(0, 0.1, 1)
                                                                                                   : Vec3(0, 0, 1);
                CHECK((m.normals[t][k] - expected.normalized()).norm() < 1e-6);
            }
    }
    SECTION("a convex polygon with corners on its edges (as modellers leave them): no zero-area triangle") {
        // A 2 x 1 rectangle with a corner halfway along its bottom and one along its
        // top: a fan from corner 0 would make (0, 1, 2), straight.
        const MeshData m = read("hexagon.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 2 1 0\nv 0.5 1 0\nv 0 1 0\nf 1 2 3 4 5 6\n");
        REQUIRE(m.triangles.size() == 4);
        for (const auto& t : m.triangles) {
            const Vec3 n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
            CHECK(n.z() > 0.1);  // each has area, none turned over
        }
        CHECK(cut_of(m, Vec3::UnitZ()).area == Approx(2.0));
    }
    SECTION("a corner repeated next to itself is no crossing") {
        const MeshData m = read("repeat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2 3\n");
        CHECK(cut_of(m, Vec3::UnitZ()).area == Approx(0.5));
        // Repeated to rounding (a UV sphere's pole at full precision): no crossing either.
        const MeshData near = read("near.obj", "v 0 0 0\nv 1 0 0\nv 0.5000000000001 1 0\nv 0.5 1 0\nf 1 2 3 4\n");
        CHECK(cut_of(near, Vec3::UnitZ()).area == Approx(0.5));
        // A corner 1e-7 of the size away is a corner of its own.
        const MeshData apart = read("apart.obj", "v 0 0 0\nv 1 0 0\nv 0.5000001 1 0\nv 0.5 1 0\nf 1 2 3 4\n");
        CHECK(apart.triangles.size() == 2);
    }
    SECTION("slightly bent quads (a few percent, as organic models have) are accepted") {
        const MeshData m = read("bent.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.05\nv 0 1 0\nf 1 2 3 4\n");
        CHECK(m.triangles.size() == 2);
    }
    SECTION("a bow tie, a pentagram, a strongly bent quad: one line each") {
        fails_with("bowtie.obj", "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n", "line 5: a polygon of 4 corners crosses");
        fails_with("star.off",
                   "OFF\n5 1 0\n0 1 0\n0.588 -0.809 0\n-0.951 0.309 0\n0.951 0.309 0\n-0.588 -0.809 0\n5 0 1 2 3 4\n",
                   "face 0: a polygon of 5 corners crosses or touches itself");
        fails_with("twisted.obj", "v 0 0 0\nv 1 0 0\nv 1 1 1\nv 0 1 0\nf 1 2 3 4\n",
                   "line 5: a polygon of 4 corners is not planar: corner");
        // In a named object: the object, and the way out.
        fails_with("monkey.obj", "o Suzanne\nv 0 0 0\nv 1 0 0\nv 1 1 1\nv 0 1 0\nf 1 2 3 4\n",
                   "line 6 (object Suzanne): a polygon of 4 corners is not planar");
        fails_with("monkey.obj", "o Suzanne\nv 0 0 0\nv 1 0 0\nv 1 1 1\nv 0 1 0\nf 1 2 3 4\n",
                   "; export the model triangulated");
    }
}

TEST_CASE("scene quads: degenerate, bent or crossing quads are refused, concave ones cut right", "[scenes][errors]") {
    auto quad = [](const std::string& points) {
        return std::string(R"({"camera": {"eye": [0, 0, 5], "target": [0, 0, 0]}, "patch_size": "none", "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}}, )") +
               R"("objects": [{"quad": )" + points + R"(, "material": "w"}]})";
    };
    auto fails_with = [&](const std::string& points, const std::string& needle) {
        INFO(points);
        REQUIRE_THROWS_WITH(parse_scene(quad(points), "s.json", "."),
                            Contains("s.json") && Contains("objects[0].quad") && Contains(needle));
    };
    fails_with("[[0,0,0], [1,0,0], [1,0,0], [0,1,0]]", "is degenerate: its points");
    fails_with("[[0,0,0], [1,0,0], [2,0,0], [0,1,0]]", "coincide or lie on one line");
    fails_with("[[0,0,0], [1,0,0], [1,1,0.001], [0,1,0]]", "is not planar");
    // The corner raised off a floor the others share is the one named.
    fails_with("[[0,0,0], [0,0,559], [556,0.01,559], [556,0,0]]",
               "is not planar: corner 2 lies 0.01 off the plane of the others");
    fails_with("[[0,0,0], [1,1,0], [1,0,0], [0,1,0]]", "crosses itself");
    // Far from the origin (coordinates up to 1e15 are promised): a 3 m quad at x = 1e9
    // was "crossing itself" (its normal was rounding).
    const Scene far = parse_scene(quad("[[1e9,0,0], [1000000003,0,0], [1000000003,3,0], [1e9,3,0]]"), "s.json", ".");
    CHECK(far.total_area() == Approx(9.0));
    const Scene arrow = parse_scene(quad("[[2,-1,0], [1,0.2,0], [2,1,0], [0,0,0]]"), "s.json", ".");
    CHECK(arrow.total_area() == Approx(1.0));
    CHECK(arrow.patch_count() == 2);
    // A hand-typed triangle likewise (it was dropped with a warning, leaving an object
    // of no patches).
    std::string triangle = quad("[[0,0,0], [0,0,559], [0,0,1000]]");
    triangle.replace(triangle.find("\"quad\""), 6, "\"triangle\"");
    REQUIRE_THROWS_WITH(parse_scene(triangle, "s.json", "."),
                        Contains("s.json: objects[0].triangle: is degenerate: its points coincide or lie on one line"));
}
