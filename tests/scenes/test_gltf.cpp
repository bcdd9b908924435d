// glTF 2.0 assets (issue 28): the node tree placed in world space, the materials
// mapped, the point lights and the first camera read; a malformed file refused in one
// line; a glTF file alone is a scene; the baked .glb out (render/patch_io.h).
#include "render/patch_io.h"
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "scenes/mesh_file.h"
#include "solver/radiance_field.h"

#include "glb_bytes.h"
#include "png_bytes.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace raybundle::scenes;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;
using nlohmann::json;
using raybundle::test::TempDir;

namespace {

std::string base64(const std::string& bytes) {
    static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const auto n = (std::uint32_t(std::uint8_t(bytes[i])) << 16) | (std::uint32_t(std::uint8_t(bytes[i + 1])) << 8) |
                       std::uint8_t(bytes[i + 2]);
        for (int k = 3; k >= 0; --k) out += digits[(n >> (6 * k)) & 63];
    }
    if (i < bytes.size()) {
        std::uint32_t n = std::uint32_t(std::uint8_t(bytes[i])) << 16;
        if (i + 1 < bytes.size()) n |= std::uint32_t(std::uint8_t(bytes[i + 1])) << 8;
        out += digits[(n >> 18) & 63];
        out += digits[(n >> 12) & 63];
        out += i + 1 < bytes.size() ? digits[(n >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

template <class T>
void append(std::string& bytes, const std::vector<T>& values) {
    bytes.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

// A unit right triangle in the xy plane facing +z (positions, normals, ushort indices,
// with 2 bytes of padding), then a quad's four corners: one buffer as a data URI.
json asset() {
    std::string bin;
    append(bin, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});  // 0..35
    append(bin, std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1});  // 36..71
    append(bin, std::vector<std::uint16_t>{0, 1, 2, 0});          // 72..79 (padded)
    return {{"asset", {{"version", "2.0"}}},
            {"scene", 0},
            {"scenes", {{{"nodes", {0}}}}},
            {"nodes",
             {{{"name", "parent"}, {"translation", {0, 0, 5}}, {"children", {1}}},
              {{"name", "tri"}, {"mesh", 0}, {"scale", {2, 2, 2}}}}},
            {"meshes",
             {{{"name", "triangle"},
               {"primitives", {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"material", 0}}}}}}},
            {"materials",
             {{{"name", "paint"},
               {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.4, 0.3, 1}}, {"metallicFactor", 0.0}}}}}},
            {"buffers", {{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + base64(bin)}}}},
            {"bufferViews",
             {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 36}},
              {{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 36}},
              {{"buffer", 0}, {"byteOffset", 72}, {"byteLength", 6}}}},
            {"accessors",
             {{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"},
               {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
              {{"bufferView", 1}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"}},
              {{"bufferView", 2}, {"componentType", 5123}, {"count", 3}, {"type", "SCALAR"}}}}};
}

MeshData parse(const json& doc) { return parse_mesh(doc.dump(), "gltf", "a.gltf"); }

using raybundle::test::glb;

std::string decoded_buffer() {
    std::string bin;
    append(bin, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
    append(bin, std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1});
    append(bin, std::vector<std::uint16_t>{0, 1, 2, 0});
    return bin;
}

}  // namespace

TEST_CASE("glTF: the node tree places its meshes in world space, mirrors keep their fronts", "[scenes][gltf]") {
    const MeshData d = parse(asset());
    REQUIRE(d.triangles.size() == 1);
    REQUIRE(d.vertices.size() == 3);
    // Scaled by 2 under a parent moved 5 along z.
    CHECK(d.vertices[1].isApprox(Vec3(2, 0, 5)));
    CHECK(d.vertices[2].isApprox(Vec3(0, 2, 5)));
    CHECK(d.groups == std::vector<std::string>{"tri"});
    REQUIRE(d.normals.size() == 1);
    CHECK(d.normals[0][0].isApprox(Vec3(0, 0, 1)));
    // A rotation of 90 degrees about x turns the face to -y; a matrix does what TRS does.
    json rotated = asset();
    rotated["nodes"][1]["rotation"] = {std::sin(M_PI / 4), 0, 0, std::cos(M_PI / 4)};
    const MeshData r = parse(rotated);
    CHECK(r.vertices[2].isApprox(Vec3(0, 0, 7)));
    CHECK(r.normals[0][0].isApprox(Vec3(0, -1, 0)));
    json matrix = asset();
    matrix["nodes"][1].erase("scale");
    matrix["nodes"][1]["matrix"] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 0, 0, 1};
    CHECK(parse(matrix).vertices[1].isApprox(Vec3(3, 0, 5)));
    // A mirror (scale -1 in x): the corners turn round so that the front, by the
    // corners' order, still faces where the file's normal does.
    json mirrored = asset();
    mirrored["nodes"][1]["scale"] = {-1, 1, 1};
    const MeshData m = parse(mirrored);
    const Vec3 e1 = m.vertices[m.triangles[0][1]] - m.vertices[m.triangles[0][0]];
    const Vec3 e2 = m.vertices[m.triangles[0][2]] - m.vertices[m.triangles[0][0]];
    CHECK(e1.cross(e2).z() > 0.0);
    CHECK(m.normals[0][0].isApprox(Vec3(0, 0, 1)));
    // The same asset as a GLB reads the same.
    const MeshData b = parse_mesh(glb(asset(), decoded_buffer()), "glb", "a.glb");
    CHECK(b.vertices == d.vertices);
    CHECK(b.triangles == d.triangles);
}

TEST_CASE("glTF: metallic-roughness, emission and sides map to our materials", "[scenes][gltf]") {
    json doc = asset();
    doc["materials"][0] = {
        {"name", "lamp"},
        {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.6, 0.4, 1}}, {"metallicFactor", 0.25}, {"roughnessFactor", 0.5}}},
        {"emissiveFactor", {1.0, 0.5, 0.25}},
        {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 8.0}}}}},
        {"doubleSided", true}};
    doc["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    const MeshData d = parse(doc);
    REQUIRE(d.material_defs.size() == 1);
    const Material& m = d.material_defs[0];
    CHECK(d.materials == std::vector<std::string>{"lamp"});
    CHECK(m.albedo.isApprox(Rgb(0.6, 0.45, 0.3)));      // base * (1 - metallic)
    CHECK(m.specular.isApprox(Rgb(0.2, 0.15, 0.1)));     // base * metallic
    CHECK(m.exponent == Approx(2.0 / 0.0625 - 2.0));     // 2 / roughness^4 - 2
    CHECK(m.emission.isApprox(Rgb(8.0, 4.0, 2.0)));      // factor * strength
    CHECK(m.two_sided);
    CHECK(d.warnings.empty());
    // Roughness 1: the lobe of exponent 0 is diffuse and joins the albedo. Without a
    // material: glTF's default, white (scaled to 0.99, with a warning).
    doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 1.0;
    CHECK(parse(doc).material_defs[0].albedo.isApprox(Rgb(0.8, 0.6, 0.4)));
    CHECK_FALSE(parse(doc).material_defs[0].glossy());
    doc["meshes"][0]["primitives"][0].erase("material");
    const MeshData plain = parse(doc);
    CHECK(plain.materials == std::vector<std::string>{"(a.gltf default)"});
    CHECK(plain.material_defs[0].albedo.isApprox(Rgb::Constant(0.99)));
    REQUIRE(plain.warnings.size() == 1);
    CHECK_THAT(plain.warnings[0], Contains("a.gltf") && Contains("default") && Contains("scaled"));
    // An extension it does not read is a warning; a required one an error.
    doc["extensionsUsed"] = {"KHR_materials_specular"};
    CHECK_THAT(parse(doc).warnings[0], Contains("KHR_materials_specular"));
    doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    CHECK_THROWS_WITH(parse(doc), Contains("a.gltf") && Contains("KHR_draco_mesh_compression"));
}

TEST_CASE("glTF: point, spot and directional lights and the first camera, placed by their nodes", "[scenes][gltf]") {
    json doc = asset();
    doc["extensionsUsed"] = {"KHR_lights_punctual"};
    doc["extensions"] = json::parse(R"({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 40.0},
        {"type": "spot", "name": "torch", "intensity": 7.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "directional", "name": "sun", "color": [1.0, 0.9, 0.8], "intensity": 3.0},
        {"type": "area", "name": "panel", "intensity": 1.0}]}})");
    doc["nodes"].push_back({{"translation", {1, 2, 3}}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    // The spot at a node turned a quarter about +x, which takes its -z to +y.
    doc["nodes"].push_back({{"translation", {0, 1, 0}},
                            {"rotation", {std::sin(M_PI / 4), 0, 0, std::cos(M_PI / 4)}},
                            {"extensions", {{"KHR_lights_punctual", {{"light", 1}}}}}});
    // The sun at a node turned a quarter about +x: it shines along +y, wherever the node is.
    doc["nodes"].push_back({{"translation", {5, 5, 5}},
                            {"rotation", {std::sin(M_PI / 4), 0, 0, std::cos(M_PI / 4)}},
                            {"extensions", {{"KHR_lights_punctual", {{"light", 2}}}}},
                            {"children", {6}}});
    // A camera 10 above the origin looking down (-z turned to -y), 4:3.
    doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", M_PI / 4}, {"aspectRatio", 4.0 / 3.0}, {"znear", 0.1}}}}};
    doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 10, 0}}, {"rotation", {-std::sin(M_PI / 4), 0, 0, std::cos(M_PI / 4)}}});
    doc["nodes"].push_back({{"extensions", {{"KHR_lights_punctual", {{"light", 3}}}}}});  // 6: a type glTF lacks
    doc["scenes"][0]["nodes"] = {0, 2, 3, 4, 5};
    const MeshData d = parse(doc);
    REQUIRE(d.point_lights.size() == 2);
    CHECK(d.point_lights[0].position.isApprox(Vec3(1, 2, 3)));
    CHECK(d.point_lights[0].intensity.isApprox(Rgb(40.0, 20.0, 10.0)));
    CHECK_FALSE(d.point_lights[0].spot());
    const PointLight& torch = d.point_lights[1];
    CHECK(torch.position.isApprox(Vec3(0, 1, 0)));
    CHECK(torch.intensity.isApprox(Rgb::Constant(7.0)));
    REQUIRE(torch.spot());
    CHECK(torch.axis.isApprox(Vec3(0, 1, 0)));
    CHECK(torch.cos_inner == Approx(std::cos(0.2)));
    CHECK(torch.cos_outer == Approx(std::cos(0.5)));
    CHECK(torch.falloff(Vec3(0, 1, 0)) == 1.0);
    CHECK(torch.falloff(Vec3(0, 0, -1)) == 0.0);
    CHECK(torch.falloff(Vec3(0, std::cos(0.35), std::sin(0.35))) ==
          Approx(std::pow((std::cos(0.35) - std::cos(0.5)) / (std::cos(0.2) - std::cos(0.5)), 2)));
    REQUIRE(d.directional_lights.size() == 1);
    CHECK(d.directional_lights[0].direction.isApprox(Vec3(0, 1, 0)));
    CHECK(d.directional_lights[0].irradiance.isApprox(Rgb(3.0, 2.7, 2.4)));
    REQUIRE(d.warnings.size() == 1);
    CHECK_THAT(d.warnings[0], Contains("panel") && Contains("an area light is not read (point, spot and directional lights are)"));
    // A light's values of the wrong type are refused (tinygltf would take its defaults),
    // a negative colour is named, an unknown key is a warning.
    auto with_light = [&](const json& light) {
        json bad = doc;
        bad["extensions"]["KHR_lights_punctual"]["lights"][0] = light;
        return bad;
    };
    CHECK_THROWS_WITH(parse(with_light({{"type", "directional"}, {"intensity", "2"}})),
                      Contains("extensions.KHR_lights_punctual.lights[0].intensity: expected a number, got \"2\""));
    CHECK_THROWS_WITH(parse(with_light({{"type", "point"}, {"color", {1, 0.5}}})),
                      Contains("extensions.KHR_lights_punctual.lights[0].color: expected [r, g, b], got [1,0.5]"));
    CHECK_THROWS_WITH(parse(with_light({{"intensity", 1}})),
                      Contains("extensions.KHR_lights_punctual.lights[0].type: missing (point, spot or directional)"));
    CHECK_THROWS_WITH(parse(with_light({{"type", "spot"}, {"spot", {{"outerConeAngle", "wide"}}}})),
                      Contains("lights[0].spot.outerConeAngle: expected a number, got \"wide\""));
    CHECK_THROWS_WITH(parse(with_light({{"type", "point"}, {"color", {1, -0.5, 1}}})),
                      Contains("light '0': color [1, -0.5, 1] is negative or not finite"));
    const MeshData extra = parse(with_light({{"type", "point"}, {"irradiance", 5}}));
    CHECK(std::any_of(extra.warnings.begin(), extra.warnings.end(), [](const std::string& w) {
        return w.find("KHR_lights_punctual.lights[0]: unknown key 'irradiance' is not read") != std::string::npos;
    }));
    // Cones out of glTF's range are refused.
    doc["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["innerConeAngle"] = 0.6;
    CHECK_THROWS_WITH(parse(doc), Contains("nodes[3]: light 'torch': innerConeAngle 0.6 is not in [0, outerConeAngle = 0.5)"));
    doc["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"] = {{"outerConeAngle", 2.0}};
    CHECK_THROWS_WITH(parse(doc), Contains("outerConeAngle 2 is not in (0, pi/2]"));
    REQUIRE(d.camera);
    CHECK(d.camera->eye.isApprox(Vec3(0, 10, 0)));
    CHECK((d.camera->target - d.camera->eye).normalized().isApprox(Vec3(0, -1, 0)));
    CHECK(d.camera->up.isApprox(Vec3(0, 0, -1)));
    CHECK(d.camera->fov_y == Approx(45.0));
    CHECK(d.camera->width == 683);
    CHECK(d.camera->height == 512);
}

TEST_CASE("glTF: a malformed file ends in one line naming the file and the object", "[scenes][gltf]") {
    const auto fails = [](const json& doc, const std::string& what) {
        INFO(what);
        try {
            parse(doc);
            FAIL("no error");
        } catch (const SceneError& e) {
            const std::string text = e.what();
            INFO(text);
            CHECK(text.find('\n') == std::string::npos);
            CHECK_THAT(text, Contains("a.gltf") && Contains(what));
        }
    };
    json doc = asset();
    doc["buffers"][0]["uri"] = "missing.bin";  // read from memory: no folder to look in
    fails(doc, "missing.bin");
    doc = asset();
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@@";
    fails(doc, "not a valid glTF");
    doc = asset();
    doc["accessors"][0]["count"] = 4;  // 48 bytes in a view of 36
    fails(doc, "accessors[0]");
    doc = asset();
    doc["accessors"][0]["count"] = 4000000000u;  // huge
    fails(doc, "do not fit");
    doc = asset();
    doc["bufferViews"][1]["byteLength"] = 1000;  // beyond its buffer
    fails(doc, "outside its buffer");
    doc = asset();
    doc["accessors"][2]["bufferView"] = 7;
    fails(doc, "invalid bufferView");  // tinygltf checks this one
    doc = asset();
    doc["accessors"][0]["componentType"] = 5123;  // positions as shorts
    fails(doc, "POSITION: expected VEC3 of FLOAT, got VEC3 of UNSIGNED_SHORT");
    doc = asset();
    doc["accessors"][2]["componentType"] = 5126;  // float indices: their type, not "do not fit"
    fails(doc, "indices (accessors[2]): expected UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, got componentType 5126");
    doc = asset();
    doc["bufferViews"][2]["byteStride"] = 4;
    fails(doc, "indices (accessors[2]): its bufferView has a byteStride (4), which glTF does not allow for indices");
    doc = asset();
    doc["accessors"][0]["count"] = 0;
    fails(doc, "POSITION (accessors[0]): count 0 (glTF asks for at least 1)");
    doc = asset();
    doc["nodes"][1]["children"] = {42};  // the index where it is written
    fails(doc, "nodes[1].children[0]: node 42 out of range (2 nodes)");
    doc = asset();
    doc["scenes"][0]["nodes"] = {0, 5};
    fails(doc, "scenes[0].nodes[1]: node 5 out of range (2 nodes)");
    doc = asset();
    doc["asset"]["version"] = "1.0";
    fails(doc, "asset.version: '1.0': raybundle reads glTF 2.0");
    // A file that needs a later reader than 2.0 says so; "2.0" is ours.
    doc = asset();
    doc["asset"]["version"] = "2.1";
    doc["asset"]["minVersion"] = "2.1";
    fails(doc, "asset.minVersion: '2.1': the file needs a reader of glTF 2.1, and raybundle reads glTF 2.0");
    doc["asset"]["minVersion"] = "2.0";
    CHECK(parse(doc).triangles.size() == 1);
    doc["asset"]["minVersion"] = "1.0";
    CHECK(parse(doc).triangles.size() == 1);
    doc["asset"]["minVersion"] = "3.0";
    fails(doc, "asset.minVersion: '3.0': the file needs a reader of glTF 3.0");
    doc["asset"]["minVersion"] = "two";
    fails(doc, "asset.minVersion: 'two' is not a version (major.minor)");
    doc = asset();
    doc["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    doc["materials"][0]["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", -5}}}};
    fails(doc, "materials[0]: KHR_materials_emissive_strength: emissiveStrength -5 is not a number >= 0");
    // An index of -1 is refused, not read as "none" (tinygltf's): the mesh, material or
    // indices would be lost silently. The application's own "extras" are not read.
    doc = asset();
    doc["nodes"][1]["mesh"] = -1;
    fails(doc, "nodes[1].mesh: -1 is not an index (glTF's indices start at 0)");
    doc = asset();
    doc["meshes"][0]["primitives"][0]["material"] = -1;
    fails(doc, "meshes[0].primitives[0].material: -1 is not an index");
    doc = asset();
    doc["meshes"][0]["primitives"][0]["indices"] = -1;
    fails(doc, "meshes[0].primitives[0].indices: -1 is not an index");
    doc = asset();
    doc["scene"] = -1;
    fails(doc, "scene: -1 is not an index");
    doc = asset();
    doc["nodes"][0]["children"] = {-1};
    fails(doc, "nodes[0].children[0]: -1 is not an index");
    doc = asset();
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = -1;
    fails(doc, "meshes[0].primitives[0].attributes.NORMAL: -1 is not an index");
    doc = asset();
    doc["meshes"][0]["primitives"][0]["targets"] = {{{"POSITION", 1}}, {{"POSITION", 0}, {"NORMAL", -1}}};
    fails(doc, "meshes[0].primitives[0].targets[1].NORMAL: -1 is not an index");
    doc = asset();
    doc["nodes"][1]["extras"] = {{"index", -1}};
    CHECK(parse(doc).triangles.size() == 1);
    // A matrix beside translation, rotation or scale (glTF forbids it): the latter would
    // be lost.
    doc = asset();
    doc["nodes"][1]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    fails(doc, "nodes[1]: has both a matrix and a scale (glTF places a node by one or the other)");
    doc = asset();
    doc["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    fails(doc, "nodes[0]: has both a matrix and a translation");
    doc = asset();
    doc["nodes"][1]["children"] = {0};  // a cycle
    fails(doc, "own ancestor");
    doc = asset();
    doc["nodes"].push_back({{"children", {1}}});  // a second parent
    doc["scenes"][0]["nodes"] = {0, 2};
    fails(doc, "nodes[1]: is placed twice, by nodes[0].children[0] and by nodes[2].children[0] (a node has one parent, "
               "and a root none)");
    doc = asset();
    doc["scenes"][0]["nodes"] = {0, 1};  // a root and a child
    fails(doc, "nodes[1]: is placed twice, by nodes[0].children[0] and by scenes[0].nodes[1]");
    doc = asset();
    doc["nodes"][1]["mesh"] = 3;
    fails(doc, "mesh 3 out of range");
    doc = asset();
    doc["accessors"][0]["sparse"] = {{"count", 1},
                                     {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                                     {"values", {{"bufferView", 0}}}};
    fails(doc, "sparse");
    doc = asset();
    doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = 2.0;
    fails(doc, "metallicFactor");
    // An index past the vertices: a triangle strip's index buffer made longer.
    std::string bin = decoded_buffer();
    bin[78] = 9;  // the fourth index (bytes 78-79), read once the count is 4
    doc = asset();
    doc["accessors"][2]["count"] = 4;
    doc["bufferViews"][2]["byteLength"] = 8;
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(bin);
    doc["meshes"][0]["primitives"][0]["mode"] = 5;
    fails(doc, "index 9");
    // Nested too deep for a recursive parser; not glTF at all; a GLB cut short.
    std::string deep = R"({"asset": {"version": "2.0"}, "extras": )" + std::string(5000, '[') + std::string(5000, ']') + "}";
    CHECK_THROWS_WITH(parse_mesh(deep, "gltf", "a.gltf"), Contains("nested"));
    CHECK_THROWS_WITH(parse_mesh("{]", "gltf", "a.gltf"), Contains("a.gltf") && Contains("not a valid glTF"));
    const std::string whole = glb(asset(), decoded_buffer());
    CHECK_THROWS_WITH(parse_mesh(whole.substr(0, whole.size() - 20), "glb", "a.glb"), Contains("a.glb"));
    // A chain of 100,000 nodes (each the child of the one before) is placed without
    // recursion: no stack overflow, the translations add up.
    doc = asset();
    const int chain = 100000;
    doc["nodes"] = json::array();
    for (int k = 0; k < chain; ++k) {
        json node = {{"translation", {0, 0, 0.001}}};
        if (k + 1 < chain) node["children"] = {k + 1};
        else node["mesh"] = 0;
        doc["nodes"].push_back(node);
    }
    CHECK(parse(doc).vertices[0].z() == Approx(100.0));
    // A GLB whose binary chunk runs past the file, or whose buffer says 0 bytes beside
    // a binary chunk (tinygltf throws std::out_of_range there): one line each.
    std::string cut = whole;
    cut.resize(cut.size() - 4);
    const std::uint32_t shorter = static_cast<std::uint32_t>(cut.size());
    std::memcpy(cut.data() + 8, &shorter, 4);  // the header agrees, the chunk does not
    CHECK_THROWS_WITH(parse_mesh(cut, "glb", "a.glb"), Contains("a.glb") && Contains("binary chunk"));
    json zero = asset();
    zero["buffers"][0].erase("uri");
    std::string zero_glb = glb(zero, decoded_buffer());
    {
        const std::uint32_t json_length = [&] { std::uint32_t w; std::memcpy(&w, zero_glb.data() + 12, 4); return w; }();
        std::string text = zero_glb.substr(20, json_length);
        const auto at = text.find("\"byteLength\":80");
        REQUIRE(at != std::string::npos);
        text.replace(at, 16, "\"byteLength\":0 ");
        zero_glb.replace(20, json_length, text);
    }
    CHECK_THROWS_AS(parse_mesh(zero_glb, "glb", "a.glb"), SceneError);
    // An image in a buffer view beyond its buffer: refused, not read past.
    doc = asset();
    doc["images"] = {{{"bufferView", 3}, {"mimeType", "image/png"}}};
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 70}, {"byteLength", 100000}});
    doc["textures"] = {{{"source", 0}}};
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    fails(doc, "outside its buffer");
    // Instancing past the triangle limit.
    doc = asset();
    for (int k = 0; k < 10; ++k) doc["nodes"].push_back({{"mesh", 0}}), doc["scenes"][0]["nodes"].push_back(2 + k);
    CHECK_THROWS_WITH(parse_mesh(doc.dump(), "gltf", "a.gltf", 5), Contains("more than 5 triangles"));
}

TEST_CASE("glTF: a warning per primitive, not per placement, unread extensions and defaults", "[scenes][gltf]") {
    json doc = asset();
    doc["meshes"][0]["primitives"].push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 1}});  // lines
    for (int k = 0; k < 1000; ++k) doc["nodes"].push_back({{"mesh", 0}}), doc["scenes"][0]["nodes"].push_back(2 + k);
    const MeshData d = parse(doc);
    CHECK(d.triangles.size() == 1001);
    REQUIRE(d.warnings.size() == 1);
    CHECK_THAT(d.warnings[0], Contains("mode 1"));
    // Each placement takes the vertices its triangles use, not its whole accessor.
    CHECK(d.vertices.size() == 3 * 1001);
    // KHR_materials_unlit is not read: a warning. KHR_materials_emissive_strength
    // without its value: 1.
    json unlit = asset();
    unlit["extensionsUsed"] = {"KHR_materials_unlit", "KHR_materials_emissive_strength"};
    unlit["materials"][0]["extensions"] = {{"KHR_materials_unlit", json::object()},
                                           {"KHR_materials_emissive_strength", json::object()}};
    unlit["materials"][0]["emissiveFactor"] = {0.5, 0.5, 0.5};
    const MeshData u = parse(unlit);
    REQUIRE(u.warnings.size() == 1);
    CHECK_THAT(u.warnings[0], Contains("KHR_materials_unlit"));
    CHECK(u.material_defs[0].emission.isApprox(Rgb::Constant(0.5)));
    // An emissiveFactor past 1 (glTF keeps it in 0..1): read as given, with a warning.
    json bright = asset();
    bright["materials"][0]["emissiveFactor"] = {5, 4, 0.5};
    const MeshData b = parse(bright);
    CHECK(b.material_defs[0].emission.isApprox(Rgb(5, 4, 0.5)));
    REQUIRE(b.warnings.size() == 1);
    CHECK(b.warnings[0] == "a.gltf: material 'paint': emissiveFactor (5, 4, 0.5) is past 1, which glTF does not allow "
                           "(KHR_materials_emissive_strength scales emission): read as given");
    // A key glTF does not define, where it decides what is placed or how it looks: a
    // warning with the nearest known key (glTF lets files carry such keys).
    json typo = asset();
    typo["nodes"][1]["translaton"] = {0, 1, 0};
    typo["materials"][0]["pbrMetallicRoughness"]["roughness"] = 0.2;
    typo["nodes"][0]["my_tag"] = 3;
    const MeshData t = parse(typo);
    CHECK(t.warnings == std::vector<std::string>{
                            "a.gltf: nodes[0]: unknown key 'my_tag' is not read",
                            "a.gltf: nodes[1]: unknown key 'translaton' is not read (did you mean 'translation'?)",
                            "a.gltf: materials[0].pbrMetallicRoughness: unknown key 'roughness' is not read (did you mean "
                            "'roughnessFactor'?)"});
    // A mesh without primitives (glTF asks for one) places nothing, with a warning.
    json empty = asset();
    empty["meshes"].push_back({{"primitives", json::array()}});
    empty["nodes"].push_back({{"mesh", 1}});
    empty["scenes"][0]["nodes"].push_back(2);
    const MeshData e = parse(empty);
    CHECK(e.triangles.size() == 1);
    REQUIRE(e.warnings.size() == 1);
    CHECK_THAT(e.warnings[0], Contains("meshes[1] (placed by nodes[2]) has no primitives"));
    // A base colour texture: the albedo is the factor (its tint) times the texture, and
    // its mean linear colour times the factor where one colour stands for it.
    const unsigned char rgba[8] = {255, 0, 0, 255, 0, 0, 255, 255};
    const std::string png = raybundle::test::png_bytes(2, 1, rgba);
    json textured = asset();
    textured["images"] = {{{"uri", "data:image/png;base64," + base64(png)}}};
    textured["textures"] = {{{"source", 0}}};
    textured["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 0.5, 1};
    textured["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    const MeshData tex = parse(textured);
    CHECK(tex.material_defs[0].albedo.isApprox(Rgb(0.5, 0, 0.25)));
    REQUIRE(tex.material_defs[0].texture);
    CHECK(tex.material_defs[0].tint.isApprox(Rgb(1, 1, 0.5)));
    CHECK(tex.material_defs[0].texture->shown == "a.gltf: images[0]");
    CHECK(tex.warnings.empty());
    // A rotation that is not of unit length: its direction, with a warning past the
    // rounding of floats (glTF asks for unit quaternions).
    json twice = asset();
    twice["nodes"][1]["rotation"] = {2 * std::sin(M_PI / 4), 0, 0, 2 * std::cos(M_PI / 4)};
    const MeshData q = parse(twice);
    CHECK(q.vertices[2].isApprox(Vec3(0, 0, 7)));
    REQUIRE(q.warnings.size() == 1);
    CHECK_THAT(q.warnings[0], StartsWith("a.gltf: nodes[1]: rotation (1.41421, 0, 0, 1.41421) has length 2, not 1"));
    twice["nodes"][1]["rotation"] = {std::sin(M_PI / 4) * 1.0002, 0, 0, std::cos(M_PI / 4) * 1.0002};
    CHECK(parse(twice).warnings.empty());
}

TEST_CASE("glTF: a file alone is a scene, its buffers beside it, in a scene file it brings its materials",
          "[scenes][gltf]") {
    TempDir dir;
    json doc = asset();
    doc["buffers"][0]["uri"] = "tri.bin";
    dir.write("tri.bin", decoded_buffer());
    doc["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.01}}}}};
    doc["nodes"].push_back({{"camera", 0}, {"translation", {0.5, 0.5, 9}}});
    doc["scenes"][0]["nodes"] = {0, 2};
    const std::string path = dir.write("tri.gltf", doc.dump());
    const Scene alone = load_scene(path);
    CHECK(alone.camera.eye.isApprox(Vec3(0.5, 0.5, 9)));
    CHECK(alone.camera.fov_y == Approx(0.8 * 180 / M_PI));
    CHECK(alone.materials[alone.find_material("paint")].albedo.isApprox(Rgb(0.5, 0.4, 0.3)));
    CHECK(std::find(alone.files.begin(), alone.files.end(), (dir.path / "tri.bin").string()) != alone.files.end());
    // -D overrides the generated document, the camera too.
    const Scene moved = load_scene(path, {{"camera.eye", "[0.5, 0.5, 20]"}});
    CHECK(moved.camera.eye.isApprox(Vec3(0.5, 0.5, 20)));
    // A camera rolled 30 degrees about its view keeps its roll with its own view; moved
    // to another, it stands level (+y up) unless camera.up is given.
    json rolled = doc;
    rolled["nodes"][2]["rotation"] = {0, 0, std::sin(M_PI / 12), std::cos(M_PI / 12)};
    const std::string rolled_path = dir.write("rolled.gltf", rolled.dump());
    const Vec3 roll(-0.5, std::sqrt(0.75), 0);
    CHECK(load_scene(rolled_path).camera.up.isApprox(roll));
    CHECK(load_scene(rolled_path, {{"camera.width", "64"}}).camera.up.isApprox(roll));
    CHECK(load_scene(rolled_path, {{"camera.eye", "[0.5, 3, 9]"}}).camera.up == Vec3(0, 1, 0));
    CHECK(load_scene(rolled_path, {{"camera.target[0]", "1"}}).camera.up == Vec3(0, 1, 0));
    CHECK(load_scene(rolled_path, {{"camera.eye", "[0.5, 3, 9]"}, {"camera.up", "[1, 1, 0]"}}).camera.up == Vec3(1, 1, 0));
    // Moved to look straight down, where +y cannot be up: the node's up stays.
    CHECK(load_scene(rolled_path, {{"camera.eye", "[0.5, 9, 0]"}, {"camera.target", "[0.5, 0, 0]"}}).camera.up.isApprox(roll));
    // One value of its material: that value, the rest as the file has it.
    const Scene lit = load_scene(path, {{"materials.paint.emission", "[2, 2, 2]"}});
    CHECK(lit.materials[lit.find_material("paint")].albedo.isApprox(Rgb(0.5, 0.4, 0.3)));
    CHECK(lit.materials[lit.find_material("paint")].emission.isApprox(Rgb::Constant(2)));
    // In a scene file: the scene's material of the same name wins.
    const std::string scene = dir.write(
        "s.json", R"({"camera": {"eye": [0, 0, 20], "target": [0, 0, 0]}, "materials": {"paint": {"albedo": [0.1, 0.2, 0.3]}},
                   "objects": [{"mesh": "tri.gltf"}]})");
    const Scene s = load_scene(scene);
    CHECK(s.materials[s.find_material("paint")].albedo.isApprox(Rgb(0.1, 0.2, 0.3)));
    // Two glTF files whose materials share a name: one material where they agree, two
    // where they differ, the second named by its file.
    json blue = doc;
    blue["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {0.1, 0.2, 0.7, 1};
    dir.write("blue.gltf", blue.dump());
    const Scene two = load_scene(dir.write("two.json", R"({"camera": {"eye": [0, 0, 20], "target": [0, 0, 0]},
        "objects": [{"mesh": "tri.gltf"}, {"mesh": "tri.gltf", "translate": [3, 0, 0]}, {"mesh": "blue.gltf", "translate": [6, 0, 0]}]})"));
    REQUIRE(two.materials.size() == 2);
    CHECK(two.materials[0].name == "paint");
    CHECK(two.materials[1].name == "paint (blue.gltf)");
    CHECK(two.materials[1].albedo.isApprox(Rgb(0.1, 0.2, 0.7)));
    CHECK(std::count_if(two.warnings.begin(), two.warnings.end(), [](const std::string& w) {
              return w.find("blue.gltf: its material 'paint' differs") != std::string::npos;
          }) == 1);
    // Emission or a point light past 1e15 (which a scene file may not give) is refused
    // as it loads, naming the file and the material or light.
    json hot = doc;
    hot["materials"][0]["emissiveFactor"] = {1, 1, 1};
    hot["materials"][0]["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", 1e300}}}};
    hot["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    CHECK_THROWS_WITH(load_scene(dir.write("hot.gltf", hot.dump())),
                      Contains("hot.gltf: material 'paint': emission 1e+300 is too large (at most 1e+15)"));
    json bright = doc;
    bright["extensionsUsed"] = {"KHR_lights_punctual"};
    bright["extensions"] = json::parse(R"({"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1e300}]}})");
    bright["nodes"].push_back({{"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    bright["scenes"][0]["nodes"] = {0, 2, 3};
    CHECK_THROWS_WITH(load_scene(dir.write("bright.gltf", bright.dump())),
                      Contains("point light 0: intensity 1e+300 is too large (at most 1e+15)"));
    // A sun: too strong is refused the same way; placed, it turns with its object (and is
    // named by its file and name in messages).
    bright["extensions"]["KHR_lights_punctual"]["lights"][0] = {{"type", "directional"}, {"intensity", 1e300}};
    CHECK_THROWS_WITH(load_scene(dir.write("bright-sun.gltf", bright.dump())),
                      Contains("directional light 0: irradiance 1e+300 is too large (at most 1e+15)"));
    bright["extensions"]["KHR_lights_punctual"]["lights"][0] = {{"type", "directional"}, {"intensity", 2.0}, {"name", "Sun"}};
    dir.write("sun.gltf", bright.dump());
    const Scene turned = load_scene(dir.write("turned.json", R"({"camera": {"eye": [0, 0, 20], "target": [0, 0, 0]},
        "objects": [{"mesh": "sun.gltf", "rotate": [90, 0, 0], "translate": [5, 0, 0]}]})"));
    REQUIRE(turned.directional_lights.size() == 1);
    CHECK(turned.directional_lights[0].direction.isApprox(Vec3(0, 1, 0)));  // -z turned a quarter about x
    CHECK(turned.directional_lights[0].irradiance.isApprox(Rgb::Constant(2.0)));
    CHECK(turned.directional_lights[0].name == "sun.gltf: light 'Sun'");
    // Written by Blender: its lights are 683 times its emission's scale, said once with
    // the -D that undoes it; light_scale scales them (and says nothing more).
    json blender = bright;
    blender["asset"]["generator"] = "Khronos glTF Blender I/O v3.4.50";
    dir.write("blender.gltf", blender.dump());
    const std::string two_suns = dir.write("suns.json", R"({"camera": {"eye": [0, 0, 20], "target": [0, 0, 0]},
        "objects": [{"mesh": "sun.gltf"}, {"mesh": "blender.gltf"}]})");
    const Scene warned = load_scene(two_suns);
    CHECK(std::count_if(warned.warnings.begin(), warned.warnings.end(), [](const std::string& w) {
              return w.find("blender.gltf: written by Blender") != std::string::npos &&
                     w.find("-D objects[1].light_scale=0.001464") != std::string::npos;
          }) == 1);
    const Scene scaled = load_scene(two_suns, {{"objects[1].light_scale", "0.5"}});
    REQUIRE(scaled.directional_lights.size() == 2);
    CHECK(scaled.directional_lights[0].irradiance.isApprox(Rgb::Constant(2.0)));  // sun.gltf's: as written
    CHECK(scaled.directional_lights[1].irradiance.isApprox(Rgb::Constant(1.0)));
    CHECK(std::none_of(scaled.warnings.begin(), scaled.warnings.end(),
                       [](const std::string& w) { return w.find("written by Blender") != std::string::npos; }));
    CHECK_THROWS_WITH(load_scene(two_suns, {{"objects[1].light_scale", "-1"}}),
                      Contains("objects[1].light_scale: must be 0 or more, got -1"));
    CHECK_THROWS_WITH(load_scene(dir.write("quad-scale.json", R"({"camera": {"eye": [0, 0, 20], "target": [0, 0, 0]},
        "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}},
        "objects": [{"quad": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "material": "w", "light_scale": 2}]})")),
                      Contains("objects[0].light_scale: scales the lights a mesh file brings (a glTF's) only"));
    // Without a camera of its own, the scene takes the glTF's, placed with its mesh.
    const Scene taken = load_scene(dir.write("c.json", R"({"objects": [{"mesh": "tri.gltf", "translate": [1, 0, 0]}]})"));
    CHECK(taken.camera.eye.isApprox(Vec3(1.5, 0.5, 9)));
    CHECK(taken.camera.fov_y == Approx(0.8 * 180 / M_PI));
    // -D camera.width alone places no eye: the glTF's camera with that width.
    const Scene wide = load_scene((dir.path / "c.json").string(), {{"camera.width", "64"}});
    CHECK(wide.camera.eye.isApprox(Vec3(1.5, 0.5, 9)));
    CHECK(wide.camera.width == 64);
    CHECK(wide.camera.height == 64);  // the height follows the glTF camera's aspect (512 x 512)
    dir.write("none.json", R"({"materials": {"w": {"albedo": [0.5, 0.5, 0.5]}},
                               "objects": [{"triangle": [[0,0,0],[1,0,0],[0,1,0]], "material": "w"}]})");
    CHECK_THROWS_WITH(load_scene((dir.path / "none.json").string()),
                      Contains("none.json: camera: missing (and no glTF mesh of the scene brings one)"));
    // A buffer outside the asset's folder is refused.
    dir.write("outside.bin", decoded_buffer());
    std::filesystem::create_directories(dir.path / "sub");
    json escape = asset();
    escape["buffers"][0]["uri"] = "../outside.bin";
    const std::string nested = (dir.path / "sub" / "x.gltf").string();
    std::ofstream(nested) << escape.dump();
    CHECK_THROWS_WITH(load_scene(nested), Contains("x.gltf: buffers[0].uri: '../outside.bin' lies outside the asset's folder"));
    // A missing buffer file names the scene, the object, the buffer and the file.
    std::filesystem::remove(dir.path / "tri.bin");
    CHECK_THROWS_WITH(load_scene(scene), Contains("s.json") && Contains("objects[0]") &&
                                             Contains("buffers[0].uri: 'tri.bin': no such file beside the asset"));
    CHECK_THROWS_WITH(load_scene(path), Contains("tri.gltf: buffers[0].uri: 'tri.bin': no such file beside the asset"));
    // A URI is decoded as tinygltf decodes it ('+' a space, %XX a byte): "my+tri%2D1.bin"
    // is "my tri-1.bin".
    dir.write("my tri-1.bin", decoded_buffer());
    json spaced = asset();
    spaced["buffers"][0]["uri"] = "my+tri%2D1.bin";
    CHECK(load_scene(dir.write("spaced.gltf", spaced.dump())).patch_count() > 0);
    // A texture file that is missing leaves its material to its factor (a warning of
    // tinygltf's, not an error).
    json textured = asset();
    textured["buffers"][0]["uri"] = "my+tri%2D1.bin";
    textured["images"] = {{{"uri", "no-such.png"}}};
    textured["textures"] = {{{"source", 0}}};
    textured["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
    CHECK(load_scene(dir.write("textured.gltf", textured.dump())).patch_count() > 0);
    // The warning says why: no such file, or one outside the asset's folder.
    const auto texture_warning = [](const MeshData& d) {
        const auto w = std::find_if(d.warnings.begin(), d.warnings.end(),
                                    [](const std::string& line) { return line.find("texture") != std::string::npos; });
        return w == d.warnings.end() ? std::string() : *w;
    };
    CHECK_THAT(texture_warning(read_mesh_file(dir.write("textured.gltf", textured.dump()), "textured.gltf")),
               Contains("'no-such.png': no such file beside the asset"));
    dir.write("outside.png", "not read");
    textured["images"][0]["uri"] = "../outside.png";
    std::filesystem::copy_file(dir.path / "my tri-1.bin", dir.path / "sub" / "my tri-1.bin");
    CHECK_THAT(texture_warning(read_mesh_file(dir.write("sub/outside.gltf", textured.dump()), "outside.gltf")),
               Contains("'../outside.png' lies outside the asset's folder (not read)"));
}

TEST_CASE("baked glb: the patches with their radiance, COLOR_0 after the exposure", "[render][gltf]") {
    TempDir dir;
    json doc = asset();
    const Scene scene = load_scene(dir.write("tri.gltf", doc.dump()));
    raybundle::solver::RadianceField field;
    field.radiance.resize(scene.patch_count());
    for (std::size_t i = 0; i < field.radiance.size(); ++i) field.radiance[i] = Rgb(0.25 * i, 0.5, 3.0);
    const std::string out = (dir.path / "lit.glb").string();
    raybundle::render::write_patch_glb(out, scene, field, 1.0);
    std::ifstream in(out, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // The reader reads it back: one triangle per patch, where the patches are.
    const MeshData back = parse_mesh(bytes, "glb", "lit.glb");
    CHECK(back.triangles.size() == scene.patch_count());
    // Its COLOR_0 (its look: the material is unlit) is not read as an albedo.
    CHECK(back.colours.empty());
    CHECK(std::any_of(back.warnings.begin(), back.warnings.end(), [](const std::string& w) {
        return w.find("COLOR_0 of an unlit material (KHR_materials_unlit) is its look, not its albedo") != std::string::npos;
    }));
    REQUIRE(bytes.size() > 20);
    std::uint32_t json_length = 0;
    std::memcpy(&json_length, bytes.data() + 12, 4);
    const json j = json::parse(bytes.substr(20, json_length));
    CHECK(j["asset"]["extras"]["exposure"] == 1.0);
    CHECK(j["extensionsUsed"] == json{"KHR_materials_unlit"});
    const std::size_t n = 3 * scene.patch_count();
    const char* bin = bytes.data() + 20 + json_length + 8;
    auto at = [&](int attribute, std::size_t vertex, int c) {
        float f;
        std::memcpy(&f, bin + (attribute * 3 * n + 3 * vertex + c) * 4, 4);
        return f;
    };
    for (std::size_t i = 0; i < scene.patch_count(); ++i)
        for (int k = 0; k < 3; ++k)
            for (int c = 0; c < 3; ++c) {
                CHECK(at(3, 3 * i + k, c) == static_cast<float>(field.radiance[i][c]));  // _RADIANCE
                CHECK(at(2, 3 * i + k, c) == static_cast<float>(std::min(1.0, 2.0 * field.radiance[i][c])));  // COLOR_0
            }
}
