// Textures (an MTL's map_Kd, a glTF's baseColorTexture) read texel by texel through
// the faces' texture coordinates: the lookup, the readers' coordinates and their
// orientation, the albedo at a point and per patch, the image against closed forms.
#include "../render/gather_options.h"
#include "render/final_gather.h"
#include "render/path_tracer.h"
#include "solver/solver.h"
#include "solver/transport.h"
#include "scenes/errors.h"
#include "scenes/loader.h"
#include "scenes/mesh_file.h"
#include "scenes/subdivide.h"
#include "scenes/texture.h"

#include "glb_bytes.h"
#include "png_bytes.h"
#include "temp_dir.h"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <png.h>

#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

using namespace raybundle::scenes;
using Catch::Matchers::Contains;
using raybundle::test::TempDir;

namespace {

// A texture of width x height texels from RGB bytes (rows top to bottom).
Texture texture_of(int width, int height, const std::vector<unsigned char>& rgb,
                   Texture::Wrap wrap = Texture::Wrap::repeat) {
    std::vector<unsigned char> rgba;
    for (std::size_t i = 0; i < rgb.size(); i += 3) rgba.insert(rgba.end(), {rgb[i], rgb[i + 1], rgb[i + 2], 255});
    std::string why;
    auto image = decode_image(raybundle::test::png_bytes(width, height, rgba.data()), &why);
    REQUIRE(image);
    Texture t;
    t.name = t.shown = "test.png";
    t.image = std::make_shared<const TexelImage>(std::move(*image));
    t.wrap_s = t.wrap_t = wrap;
    return t;
}

Rgb linear(unsigned char r, unsigned char g, unsigned char b) {
    return Rgb(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b));
}

// 4 x 4 texels, each of its own colour: texel (i, j) (column i, row j from the top)
// is (40 + 60 i, 30 + 70 j, 200 - 40 i).
std::vector<unsigned char> sixteen() {
    std::vector<unsigned char> rgb;
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i)
            rgb.insert(rgb.end(), {static_cast<unsigned char>(40 + 60 * i), static_cast<unsigned char>(30 + 70 * j),
                                   static_cast<unsigned char>(200 - 40 * i)});
    return rgb;
}
Rgb sixteen_at(int i, int j) {
    return linear(static_cast<unsigned char>(40 + 60 * i), static_cast<unsigned char>(30 + 70 * j),
                  static_cast<unsigned char>(200 - 40 * i));
}

// Whether patch i's triangle holds the point x (on its plane).
bool holds(const Scene& scene, std::size_t i, const Vec3& x) {
    const auto& pos = scene.vertex_positions();
    const auto& p = scene.patch_list()[i];
    const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
    return std::abs(p.normal.dot(x - a)) <= 1e-9 && p.normal.dot((b - a).cross(x - a)) >= -1e-12 &&
           p.normal.dot((c - b).cross(x - b)) >= -1e-12 && p.normal.dot((a - c).cross(x - c)) >= -1e-12;
}

// The first patch of `scene` whose triangle holds the point x.
std::size_t patch_at(const Scene& scene, const Vec3& x) {
    for (std::size_t i = 0; i < scene.patch_count(); ++i)
        if (holds(scene, i, x)) return i;
    FAIL("no patch holds the point");
    return 0;
}

}  // namespace

TEST_CASE("Texture: bilinear between texel centres, wrapped as its sampler says", "[scenes][texture]") {
    // Two texels: red, then blue.
    const std::vector<unsigned char> rgb = {255, 0, 0, 0, 0, 255};
    const Rgb red(1, 0, 0), blue(0, 0, 1);
    for (const auto wrap : {Texture::Wrap::repeat, Texture::Wrap::clamp, Texture::Wrap::mirror}) {
        const Texture t = texture_of(2, 1, rgb, wrap);
        CHECK(t.at(0.25, 0.5).isApprox(red));  // the texel centres: the texels
        CHECK(t.at(0.75, 0.5).isApprox(blue));
        CHECK(t.at(0.5, 0.5).isApprox(0.5 * (red + blue)));
        CHECK(t.at(0.375, 0.5).isApprox(0.75 * red + 0.25 * blue));
        CHECK(t.at(0.25, 7.3).isApprox(red));  // one row: t changes nothing
        CHECK(t.mean().isApprox(0.5 * (red + blue)));
    }
    // Past the edges.
    const Texture repeat = texture_of(2, 1, rgb, Texture::Wrap::repeat);
    CHECK(repeat.at(0.0, 0.5).isApprox(0.5 * (red + blue)));  // between the last texel and the first
    CHECK(repeat.at(1.25, 0.5).isApprox(red));
    CHECK(repeat.at(-0.25, 0.5).isApprox(blue));
    CHECK(repeat.at(-1e6 + 0.25, 0.5).isApprox(red));
    const Texture clamp = texture_of(2, 1, rgb, Texture::Wrap::clamp);
    CHECK(clamp.at(0.0, 0.5).isApprox(red));
    CHECK(clamp.at(-3.0, 0.5).isApprox(red));
    CHECK(clamp.at(5.0, 0.5).isApprox(blue));
    const Texture mirror = texture_of(2, 1, rgb, Texture::Wrap::mirror);
    CHECK(mirror.at(-0.25, 0.5).isApprox(red));  // red blue | blue red | red blue
    CHECK(mirror.at(1.0, 0.5).isApprox(blue));
    CHECK(mirror.at(1.25, 0.5).isApprox(blue));
    CHECK(mirror.at(1.75, 0.5).isApprox(red));
    // Not finite: the mean.
    CHECK(repeat.at(std::nan(""), 0.5).isApprox(repeat.mean()));
    // sRGB decoded, alpha left out; the brightest texels per channel.
    const Texture grey = texture_of(1, 1, {128, 64, 0});
    CHECK(grey.at(0.5, 0.5)[0] == Approx(std::pow((128 / 255.0 + 0.055) / 1.055, 2.4)));
    CHECK(texture_of(2, 1, {10, 200, 30, 90, 20, 60}).image->brightest.isApprox(linear(90, 200, 60)));
    // A 16-bit PNG (libpng's simplified writer tags it linear, gAMA 1): its values read
    // as sRGB all the same, as glTF asks and Blender reads them, rounded to 8 bits.
    {
        const std::uint16_t rgb16[3] = {32896, 16448, 65535};  // 128, 64 and 255 times 257
        png_image image{};
        image.version = PNG_IMAGE_VERSION;
        image.width = image.height = 1;
        image.format = PNG_FORMAT_LINEAR_RGB;
        png_alloc_size_t size = 0;
        REQUIRE(png_image_write_to_memory(&image, nullptr, &size, 0, rgb16, 0, nullptr));
        std::string bytes(size, '\0');
        REQUIRE(png_image_write_to_memory(&image, bytes.data(), &size, 0, rgb16, 0, nullptr));
        const auto wide = decode_image(bytes.substr(0, size));
        REQUIRE(wide);
        CHECK(wide->srgb == std::vector<std::uint8_t>{128, 64, 255});
    }
    std::string why;
    CHECK_FALSE(decode_image("GIF89a", &why));
    CHECK(why == "not a PNG or JPEG");
}

TEST_CASE("OBJ: vt read per face corner, v turned to t down from the image's top", "[scenes][texture][obj]") {
    const MeshData d = parse_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0.25 0.75\nvt 1 0 0\nvt 0.5\n"
                                  "f 1/1 2/2 3/3\nf 2 4 3\n",
                                  "obj", "t.obj");
    REQUIRE(d.uvs.size() == 2);
    CHECK(d.uvs[0][0] == Uv(0.25, 0.25));
    CHECK(d.uvs[0][1] == Uv(1.0, 1.0));
    CHECK(d.uvs[0][2] == Uv(0.5, 1.0));  // v 0 where not given
    CHECK_FALSE(d.uvs[1][0].allFinite());  // a face without them: NaN
    // A quad's fan keeps each corner's.
    const MeshData q = parse_mesh("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                  "f 1/1 2/2 3/3 4/4\n",
                                  "obj", "q.obj");
    REQUIRE(q.uvs.size() == 2);
    for (std::size_t t = 0; t < 2; ++t)
        for (int k = 0; k < 3; ++k) {
            const Vec3& v = q.vertices[static_cast<std::size_t>(q.triangles[t][k])];
            CHECK(q.uvs[t][k] == Uv(v.x(), 1.0 - v.y()));
        }
    // No vt in the file: none.
    CHECK(parse_mesh("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj", "t.obj").uvs.empty());
    // Refused in one line.
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    CHECK_THROWS_WITH(parse_mesh(tri + "vt 0 0\nvt 1 0\nf 1/1 2/2 3\n", "obj", "t.obj"),
                      "t.obj: line 6: face gives texture coordinates at 2 of its 3 corners");
    CHECK_THROWS_WITH(parse_mesh(tri + "vt 0 0\nf 1/1 2/2 3/1\n", "obj", "t.obj"),
                      "t.obj: line 5: face references texture coordinate 2, but only 1 texture coordinate is "
                      "defined before it");
    CHECK_THROWS_WITH(parse_mesh(tri + "vt 0 x\n", "obj", "t.obj"),
                      "t.obj: line 4: texture coordinate 'x' is not a number");
    // One not finite, as exporters write at degenerate faces: no coordinates there.
    const MeshData nan = parse_mesh(tri + "vt 0 nan\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n", "obj", "t.obj");
    REQUIRE(nan.uvs.size() == 1);
    CHECK_FALSE(nan.uvs[0][0].allFinite());
    CHECK(nan.uvs[0][1] == Uv(1.0, 1.0));
    CHECK_THROWS_WITH(parse_mesh(tri + "vt\n", "obj", "t.obj"), "t.obj: line 4: vt needs 1 to 3 numbers, got 0");
}

TEST_CASE("OBJ and MTL: a map_Kd through vt is the albedo texel by texel, and each patch's its mean over it",
          "[scenes][texture][obj]") {
    TempDir dir;
    const std::vector<unsigned char> rgb = sixteen();
    std::vector<unsigned char> rgba;
    for (std::size_t i = 0; i < rgb.size(); i += 3) rgba.insert(rgba.end(), {rgb[i], rgb[i + 1], rgb[i + 2], 255});
    dir.write("tiles.png", raybundle::test::png_bytes(4, 4, rgba.data()));
    dir.write("t.mtl", "newmtl tiles\nKd 0.5 0.5 0.5\nmap_Kd tiles.png\n");
    // A floor quad y = 0, x and z in 0..1; vt (0, 0) at x = 0, z = 1: the image's bottom
    // left, so that (s, t) = (x, z).
    dir.write("t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n"
                       "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\nusemtl tiles\nf 1/1 4/4 3/3 2/2\n");
    for (const std::string size : {"\"none\"", "0.3"}) {
        INFO("patch_size " << size);
        const std::string text = R"({"camera": {"eye": [0.5, 2, 0.5], "target": [0.5, 0, 0.5], "up": [0, 0, -1]},
                                     "patch_size": )" + size + R"(, "objects": [{"mesh": "t.obj"}]})";
        const Scene scene = parse_scene(text, "s.json", dir.path.string());
        CHECK(scene.warnings.empty());
        REQUIRE(scene.textured());
        const Material& m = scene.materials[0];
        REQUIRE(m.texture);
        CHECK(m.albedo.isApprox(m.texture->mean()));  // the texture itself, not times Kd
        // At each texel's centre, its colour.
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                const Vec3 x((i + 0.5) / 4, 0.0, (j + 0.5) / 4);
                CHECK(scene.albedo_at(patch_at(scene, x), x).isApprox(sixteen_at(i, j), 1e-12));
            }
        // The patches' albedos weighted by area: the texture's mean (bilinear over a whole
        // period of a repeated texture keeps it), within the points' quadrature.
        Rgb sum = Rgb::Zero();
        for (std::size_t i = 0; i < scene.patch_count(); ++i) sum += scene.patch_list()[i].area * scene.albedo_of(i);
        CHECK((sum / scene.total_area() - m.texture->mean()).abs().maxCoeff() < 2e-3);
        // Each patch's: near the mean of albedo_at over it.
        const auto& pos = scene.vertex_positions();
        for (std::size_t i = 0; i < scene.patch_count(); ++i) {
            const auto& p = scene.patch_list()[i];
            Rgb mean = Rgb::Zero();
            const int n = 200;
            for (int a = 0; a < n; ++a)
                for (int b = 0; a + b < n; ++b) {
                    const double u = (a + 1.0 / 3.0) / n, v = (b + 1.0 / 3.0) / n;
                    mean += scene.albedo_at(i, pos[p.v[0]] + u * (pos[p.v[1]] - pos[p.v[0]]) +
                                                   v * (pos[p.v[2]] - pos[p.v[0]]));
                }
            mean /= n * (n + 1) / 2.0;
            CHECK((scene.albedo_of(i) - mean).abs().maxCoeff() < 0.01);
        }
    }
    // -D: a specular keeps the texture, an albedo takes its place.
    const std::string text = R"({"camera": {"eye": [0.5, 2, 0.5], "target": [0.5, 0, 0.5], "up": [0, 0, -1]},
                                 "objects": [{"mesh": "t.obj"}]})";
    const Overrides glossy = {{"materials.tiles.specular", "[0.1, 0.1, 0.1]"}, {"materials.tiles.exponent", "20"}};
    CHECK(parse_scene(text, "s.json", dir.path.string(), glossy).textured());
    // (Its brightest texels, 0.87 in g, and a specular past 0.13 reflect more than 1.)
    CHECK_THROWS_WITH(parse_scene(text, "s.json", dir.path.string(),
                                  {{"materials.tiles.specular", "[0.2, 0.2, 0.2]"}, {"materials.tiles.exponent", "20"}}),
                      Contains("materials.tiles: its texture's brightest texels + specular = 1.07") &&
                          Contains("in channel g") && Contains("a specular of at most 0.128"));
    const Scene grey = parse_scene(text, "s.json", dir.path.string(), {{"materials.tiles.albedo", "[0.3, 0.3, 0.3]"}});
    CHECK_FALSE(grey.textured());
    CHECK(grey.albedo_of(0).isApprox(Rgb::Constant(0.3)));
    // map_Kd -o and -s (u, v up): the texture at offset + scale (u, v); -clamp on.
    dir.write("moved.mtl", "newmtl tiles\nmap_Kd -s 2 2 1 -o 0.25 0.125 -clamp on tiles.png\n");
    dir.write("moved.obj", "mtllib moved.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n"
                           "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\nusemtl tiles\nf 1/1 4/4 3/3 2/2\n");
    const Scene moved = parse_scene(R"({"camera": {"eye": [0.5, 2, 0.5], "target": [0.5, 0, 0.5], "up": [0, 0, -1]},
                                        "objects": [{"mesh": "moved.obj"}]})",
                                    "s.json", dir.path.string());
    REQUIRE(moved.materials[0].texture);
    CHECK(moved.materials[0].texture->wrap_s == Texture::Wrap::clamp);
    for (const Vec3& x : {Vec3(0.1, 0, 0.2), Vec3(0.3, 0, 0.9), Vec3(0.8, 0, 0.45)}) {
        const double u = 0.25 + 2 * x.x(), v = 0.125 + 2 * (1 - x.z());  // vt v = 1 - z here
        CHECK(moved.albedo_at(patch_at(moved, x), x).isApprox(moved.materials[0].texture->at(u, 1 - v), 1e-12));
    }
    // A mesh naming the material an earlier one brought reads it through its own vt; a
    // quad naming it has none: its mean, with a warning.
    const Scene twice = parse_scene(R"({"camera": {"eye": [0.5, 2, 0.5], "target": [0.5, 0, 0.5], "up": [0, 0, -1]},
                                        "objects": [{"mesh": "t.obj"},
                                                    {"mesh": "t.obj", "material": "tiles", "translate": [2, 0, 0]},
                                                    {"quad": [[0, 0, 2], [1, 0, 2], [1, 0, 3], [0, 0, 3]],
                                                     "material": "tiles"}]})",
                                    "s.json", dir.path.string());
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const Vec3 x(2.0 + (i + 0.5) / 4, 0.0, (j + 0.5) / 4);
            CHECK(twice.albedo_at(patch_at(twice, x), x).isApprox(sixteen_at(i, j), 1e-12));
        }
    const Vec3 on_quad(0.3, 0.0, 2.4);
    CHECK(twice.albedo_at(patch_at(twice, on_quad), on_quad).isApprox(twice.materials[0].texture->mean()));
    REQUIRE(twice.warnings.size() == 1);
    CHECK_THAT(twice.warnings[0], Contains("objects[2] (quad): 2 of 2 triangles give no texture coordinates"));
    // Faces without vt: the texture's mean there, and a warning that says so.
    dir.write("bare.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nusemtl tiles\nf 1 4 3 2\n");
    const Scene bare = parse_scene(R"({"camera": {"eye": [0.5, 2, 0.5], "target": [0.5, 0, 0.5], "up": [0, 0, -1]},
                                       "objects": [{"mesh": "bare.obj"}]})",
                                   "s.json", dir.path.string());
    CHECK_FALSE(bare.textured());
    CHECK(bare.albedo_of(0).isApprox(bare.materials[0].texture->mean()));
    REQUIRE(bare.warnings.size() == 1);
    CHECK_THAT(bare.warnings[0], Contains("objects[0] (bare.obj: tiles): 2 of 2 triangles give no texture coordinates: "
                                          "there its texture tiles.png is read as its mean colour"));
}

TEST_CASE("glTF: a baseColorTexture through its TEXCOORD_n, t down from the image's top, times the factor",
          "[scenes][texture][gltf]") {
    using nlohmann::json;
    const std::vector<unsigned char> rgb = sixteen();
    std::vector<unsigned char> rgba;
    for (std::size_t i = 0; i < rgb.size(); i += 3) rgba.insert(rgba.end(), {rgb[i], rgb[i + 1], rgb[i + 2], 255});
    const std::string png = raybundle::test::png_bytes(4, 4, rgba.data());
    // A unit quad in the xy plane facing +z, (s, t) = (x, 1 - y): the image upright as
    // seen from +z, its top at y = 1. TEXCOORD_1 is the one read.
    std::string bin;
    const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const std::vector<float> uv0 = {9, 9, 9, 9, 9, 9, 9, 9};
    const std::vector<float> uv1 = {0, 1, 1, 1, 1, 0, 0, 0};
    const std::vector<std::uint16_t> indices = {0, 1, 2, 0, 2, 3};
    bin.append(reinterpret_cast<const char*>(positions.data()), 48);
    bin.append(reinterpret_cast<const char*>(uv0.data()), 32);
    bin.append(reinterpret_cast<const char*>(uv1.data()), 32);
    bin.append(reinterpret_cast<const char*>(indices.data()), 12);
    const std::size_t image_at = bin.size();
    bin += png;
    json doc = {
        {"asset", {{"version", "2.0"}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"meshes",
         {{{"primitives",
            {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}, {"TEXCOORD_1", 2}}}, {"indices", 3}, {"material", 0}}}}}}},
        {"materials",
         {{{"name", "tiles"},
           {"pbrMetallicRoughness",
            {{"baseColorFactor", {1, 0.5, 1, 1}}, {"metallicFactor", 0.0}, {"baseColorTexture", {{"index", 0}, {"texCoord", 1}}}}}}}},
        {"textures", {{{"source", 0}, {"sampler", 0}}}},
        {"samplers", {{{"wrapS", 33071}, {"wrapT", 33648}}}},
        {"images", {{{"bufferView", 4}, {"mimeType", "image/png"}}}},
        {"buffers", {{{"byteLength", bin.size()}}}},
        {"bufferViews",
         {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
          {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 32}},
          {{"buffer", 0}, {"byteOffset", 80}, {"byteLength", 32}},
          {{"buffer", 0}, {"byteOffset", 112}, {"byteLength", 12}},
          {{"buffer", 0}, {"byteOffset", image_at}, {"byteLength", png.size()}}}},
        {"accessors",
         {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}, {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
          {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
          {{"bufferView", 2}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
          {{"bufferView", 3}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}}};
    auto glb = [&bin](const json& d) { return raybundle::test::glb(d, bin); };
    TempDir dir;
    dir.write("tiles.glb", glb(doc));
    const std::string scene_text = R"({"camera": {"eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0]}, "patch_size": 0.3,
                                       "objects": [{"mesh": "tiles.glb"}]})";
    const Scene scene = parse_scene(scene_text, "s.json", dir.path.string());
    CHECK(scene.warnings.empty());
    REQUIRE(scene.textured());
    const Material& m = scene.materials[0];
    CHECK(m.tint.isApprox(Rgb(1, 0.5, 1)));
    CHECK(m.albedo.isApprox(Rgb(1, 0.5, 1) * m.texture->mean()));
    CHECK(m.texture->wrap_s == Texture::Wrap::clamp);
    CHECK(m.texture->wrap_t == Texture::Wrap::mirror);
    CHECK(m.texture->shown == "tiles.glb: images[0]");
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const Vec3 x((i + 0.5) / 4, 1.0 - (j + 0.5) / 4, 0.0);  // texel (i, j): column i, row j from the top
            CHECK(scene.albedo_at(patch_at(scene, x), x).isApprox(Rgb(1, 0.5, 1) * sixteen_at(i, j), 1e-12));
        }
    // KHR_texture_transform: (s, t) = offset + R(rotation) (scale * uv), and its texCoord
    // (here 1, over the texture's 0).
    json moved = doc;
    moved["extensionsUsed"] = {"KHR_texture_transform"};
    moved["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {
        {"index", 0}, {"texCoord", 0},
        {"extensions", {{"KHR_texture_transform", {{"offset", {0.25, 0.125}}, {"rotation", 0.5}, {"scale", {2, 3}},
                                                   {"texCoord", 1}}}}}};
    dir.write("moved.glb", glb(moved));
    const Scene turned = parse_scene(R"({"camera": {"eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0]}, "patch_size": 0.3,
                                         "objects": [{"mesh": "moved.glb"}]})",
                                     "s.json", dir.path.string());
    CHECK(turned.warnings.empty());
    for (const Vec3& x : {Vec3(0.1, 0.2, 0), Vec3(0.7, 0.4, 0), Vec3(0.35, 0.9, 0)}) {
        const Uv uv(x.x(), 1.0 - x.y());  // TEXCOORD_1 at x
        Eigen::Matrix2d r;
        r << std::cos(0.5), std::sin(0.5), -std::sin(0.5), std::cos(0.5);
        const Uv st = Uv(0.25, 0.125) + r * Uv(2 * uv.x(), 3 * uv.y());
        CHECK(turned.albedo_at(patch_at(turned, x), x).isApprox(Rgb(1, 0.5, 1) * m.texture->at(st.x(), st.y()), 1e-12));
    }
    moved["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"]["scale"] = 2;
    CHECK_THROWS_WITH(parse_mesh(glb(moved), "glb", "moved.glb"),
                      Contains("baseColorTexture: KHR_texture_transform") && Contains("scale is not two numbers"));
    // Two-sided: the twin facing -z reads the same texels at the same points.
    json sheet = doc;
    sheet["materials"][0]["doubleSided"] = true;
    dir.write("sheet.glb", glb(sheet));
    const Scene both = parse_scene(R"({"camera": {"eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0]}, "patch_size": 0.3,
                                       "objects": [{"mesh": "sheet.glb"}]})",
                                   "s.json", dir.path.string());
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const Vec3 x((i + 0.5) / 4, 1.0 - (j + 0.5) / 4, 0.0);
            int sides = 0;
            for (std::size_t p = 0; p < both.patch_count(); ++p)
                if (holds(both, p, x)) {
                    ++sides;
                    CHECK(both.albedo_at(p, x).isApprox(Rgb(1, 0.5, 1) * sixteen_at(i, j), 1e-12));
                }
            CHECK(sides >= 2);
        }
    // Refused in one line.
    auto fails = [&](const json& d, const std::string& what) {
        dir.write("bad.glb", glb(d));
        CHECK_THROWS_WITH(parse_mesh(glb(d), "glb", "bad.glb"), Contains(what));
    };
    json bad = doc;
    bad["samplers"][0]["wrapS"] = 9728;
    fails(bad, "bad.glb: samplers[0]: wrapS 9728 is not 10497, 33071 or 33648");
    bad = doc;
    bad["accessors"][2]["count"] = 3;
    fails(bad, "bad.glb: meshes[0].primitives[0]: TEXCOORD_1: 3 texture coordinates for 4 positions");
    bad = doc;
    bad["accessors"][2]["type"] = "VEC3";
    bad["accessors"][2]["count"] = 2;
    fails(bad, "TEXCOORD_1: expected VEC2 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT, got VEC3 of FLOAT");
    // Normalized unsigned shorts: 0..65535 is 0..1.
    json shorts = doc;
    std::string more = bin;
    const std::vector<std::uint16_t> uv_shorts = {0, 65535, 65535, 65535, 65535, 0, 0, 0};
    shorts["bufferViews"][2] = {{"buffer", 0}, {"byteOffset", more.size()}, {"byteLength", 16}};
    more.append(reinterpret_cast<const char*>(uv_shorts.data()), 16);
    shorts["buffers"][0]["byteLength"] = more.size();
    shorts["accessors"][2] = {{"bufferView", 2}, {"componentType", 5123}, {"normalized", true}, {"count", 4}, {"type", "VEC2"}};
    std::swap(bin, more);
    const MeshData d = parse_mesh(glb(shorts), "glb", "s.glb");
    std::swap(bin, more);
    REQUIRE(d.uvs.size() == 2);
    CHECK(d.uvs[0][1] == Uv(1.0, 1.0));
    CHECK(d.uvs[0][2] == Uv(1.0, 0.0));
}

TEST_CASE("a textured plane under a sun: each pixel the texture's albedo there times E cos / pi, path traced and "
          "gathered",
          "[render][texture][pathtrace][gather]") {
    // 16 x 16 texels in 4 x 4 blocks of one colour each: between the centres of a
    // block's texels the bilinear lookup is that colour.
    std::vector<unsigned char> rgb;
    for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 16; ++i)
            rgb.insert(rgb.end(), {static_cast<unsigned char>(40 + 60 * (i / 4)), static_cast<unsigned char>(30 + 70 * (j / 4)),
                                   static_cast<unsigned char>(200 - 40 * (i / 4))});
    Scene scene;
    Material ground;
    ground.name = "ground";
    ground.texture = std::make_shared<const Texture>(texture_of(16, 16, rgb));
    ground.tint = Rgb(0.9, 0.8, 0.7);
    ground.albedo = ground.tint * ground.texture->mean();
    const int g = scene.add_material(ground);
    const std::vector<std::array<Uv, 3>> uvs = {{Uv(0, 1), Uv(1, 1), Uv(1, 0)}, {Uv(0, 1), Uv(1, 0), Uv(0, 0)}};
    scene.add_object({{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, g, "ground", -1, {},
                     uvs);
    scene.finalize();
    subdivide(scene, 0.2);
    REQUIRE(scene.textured());
    const Vec3 along = Vec3(1.0, 0.5, -2.0).normalized();
    scene.directional_lights.push_back({along, Rgb(2.0, 3.0, 4.0), "sun"});
    scene.camera.eye = Vec3(0, 0, 3);
    scene.camera.target = Vec3(0, 0, 0);
    scene.camera.fov_y = 50;
    scene.camera.width = scene.camera.height = 32;
    const RayCaster caster(scene);
    const raybundle::render::PinholeCamera camera(scene.camera);
    raybundle::render::PathTraceOptions po;
    po.spp = 16;
    const auto traced = raybundle::render::path_trace(scene, caster, camera, po, {}).image;
    const raybundle::solver::Transport transport(scene, raybundle::solver::ShotOptions{true});
    raybundle::solver::SolverOptions so;
    so.steps = 200;
    auto solver = raybundle::solver::make_solver(transport, so, {});
    solver->run();
    raybundle::render::GatherOptions go = guide_only_gather();
    go.gather_rays = 4;
    go.filter.filter = raybundle::render::Filter::none;
    const auto gathered = raybundle::render::final_gather(scene, caster, solver->field(), camera, go, {}).image;
    const Rgb light = scene.directional_lights[0].irradiance * (-along.z() / M_PI);
    int exact = 0;
    std::vector<Rgb> seen;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            // Where the pixel's centre and corners meet the plane with one albedo, its
            // every sample does.
            std::vector<Rgb> albedos;
            for (const auto& [dx, dy] : {std::pair{0.5, 0.5}, {0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}, {1.0, 1.0}}) {
                const auto hit = caster.intersect(camera.eye(), camera.direction(x + dx, y + dy));
                if (!hit.valid()) break;
                albedos.push_back(
                    scene.albedo_at(static_cast<std::size_t>(hit.patch), camera.eye() + hit.t * camera.direction(x + dx, y + dy)));
            }
            if (albedos.size() < 5) continue;
            // The gather's one guide point is the pixel's centre.
            for (int k = 0; k < 3; ++k) CHECK(gathered.at(x, y)[k] == Approx(albedos[0][k] * light[k]).epsilon(1e-5));
            bool one = true;
            for (const Rgb& a : albedos) one = one && a.isApprox(albedos[0], 1e-12);
            if (!one) continue;
            ++exact;
            for (int k = 0; k < 3; ++k) CHECK(traced.at(x, y)[k] == Approx(albedos[0][k] * light[k]).epsilon(1e-5));
            if (std::none_of(seen.begin(), seen.end(), [&](const Rgb& c) { return c.isApprox(albedos[0], 1e-9); }))
                seen.push_back(albedos[0]);
        }
    INFO(exact << " pixels of one albedo, " << seen.size() << " albedos among them");
    CHECK(exact > 150);  // (196: a third of the plane's pixels)
    CHECK(seen.size() >= 12);  // the blocks' colours are in the image
}

TEST_CASE("a texture repeated many times over a patch: its mean, not one of its colours", "[scenes][texture]") {
    // A black and white checker of 2 x 2 texels, repeated 1,000 times along each side
    // of a square of two patches as modelled: a grid of 64 x 64 points would fall in
    // step with it.
    Scene scene;
    Material m;
    m.name = "tiles";
    m.texture = std::make_shared<const Texture>(texture_of(2, 2, {255, 255, 255, 0, 0, 0, 0, 0, 0, 255, 255, 255}));
    m.albedo = m.texture->mean();
    m.tint = Rgb::Constant(0.8);
    const int t = scene.add_material(m);
    for (const double tiles : {1000.0, 1024.0, 997.5}) {
        INFO(tiles << " repeats");
        Scene one = scene;
        one.add_object({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, t, "floor", -1, {},
                       {{Uv(0, tiles), Uv(tiles, tiles), Uv(tiles, 0)}, {Uv(0, tiles), Uv(tiles, 0), Uv(0, 0)}});
        one.finalize();
        REQUIRE(one.patch_count() == 2);
        for (std::size_t i = 0; i < 2; ++i) CHECK(one.albedo_of(i)[0] == Approx(0.4).epsilon(0.03));
    }
}

// ------------------------------------------------------------------ vertex colours

namespace {

// The colour at x of the triangle (a, b, c) whose corners have the colours ca, cb, cc:
// barycentric weights from areas.
Rgb interpolated(const Vec3& a, const Vec3& b, const Vec3& c, const Rgb& ca, const Rgb& cb, const Rgb& cc,
                 const Vec3& x) {
    const double whole = (b - a).cross(c - a).norm();
    const double wa = (b - x).cross(c - x).norm() / whole, wb = (c - x).cross(a - x).norm() / whole;
    return wa * ca + wb * cb + (1.0 - wa - wb) * cc;
}

}  // namespace

TEST_CASE("glTF: COLOR_0 multiplies the base colour, interpolated across each triangle, exact after refinement",
          "[scenes][texture][colour][gltf]") {
    using nlohmann::json;
    // A unit quad facing +z (two triangles 0 1 2, 0 2 3), COLOR_0 as normalized bytes
    // with alpha (VEC4: its alpha unread).
    std::string bin;
    const std::vector<float> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const std::vector<unsigned char> bytes = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0, 255, 255, 255, 255};
    const std::vector<std::uint16_t> indices = {0, 1, 2, 0, 2, 3};
    bin.append(reinterpret_cast<const char*>(positions.data()), 48);
    bin.append(reinterpret_cast<const char*>(bytes.data()), 16);
    bin.append(reinterpret_cast<const char*>(indices.data()), 12);
    json doc = {
        {"asset", {{"version", "2.0"}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}}, {"indices", 2}, {"material", 0}}}}}}},
        {"materials",
         {{{"name", "paint"}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.6, 0.4, 1}}, {"metallicFactor", 0.0}}}}}},
        {"buffers", {{{"byteLength", bin.size()}}}},
        {"bufferViews",
         {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 48}},
          {{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 16}},
          {{"buffer", 0}, {"byteOffset", 64}, {"byteLength", 12}}}},
        {"accessors",
         {{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}, {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
          {{"bufferView", 1}, {"componentType", 5121}, {"normalized", true}, {"count", 4}, {"type", "VEC4"}},
          {{"bufferView", 2}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}}}}};
    TempDir dir;
    dir.write("colours.glb", raybundle::test::glb(doc, bin));
    const auto scene_of = [&](const std::string& mesh, double patch_size) {
        return parse_scene(R"({"camera": {"eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0]}, "patch_size": )" +
                               std::to_string(patch_size) + R"(, "objects": [{"mesh": ")" + mesh + R"("}]})",
                           "s.json", dir.path.string());
    };
    const Scene scene = scene_of("colours.glb", 0.1);
    CHECK(scene.warnings.empty());
    REQUIRE(scene.textured());
    const Rgb base(0.8, 0.6, 0.4);
    const Vec3 p0(0, 0, 0), p1(1, 0, 0), p2(1, 1, 0), p3(0, 1, 0);
    const Rgb c0(1, 0, 0), c1(0, 1, 0), c2(0, 0, 1), c3(1, 1, 1);
    for (const Vec3& x : {Vec3(0.9, 0.05, 0), Vec3(0.7, 0.3, 0), Vec3(0.99, 0.98, 0)})  // in triangle 0 1 2
        CHECK(scene.albedo_at(patch_at(scene, x), x).isApprox(base * interpolated(p0, p1, p2, c0, c1, c2, x), 1e-12));
    for (const Vec3& x : {Vec3(0.05, 0.9, 0), Vec3(0.3, 0.7, 0), Vec3(0.01, 0.02, 0)})  // in triangle 0 2 3
        CHECK(scene.albedo_at(patch_at(scene, x), x).isApprox(base * interpolated(p0, p2, p3, c0, c2, c3, x), 1e-12));
    // Each patch reflects its mean: the colour at its centroid. Over the quad, the
    // area-weighted sum is each triangle's area times its corners' mean.
    Rgb sum = Rgb::Zero();
    std::size_t coloured = 0;
    for (std::size_t i = 0; i < scene.patch_count(); ++i) {
        const auto& p = scene.patch_list()[i];
        CHECK(scene.albedo_of(i).isApprox(scene.albedo_at(i, p.centroid), 1e-12));
        sum += p.area * scene.albedo_of(i);
        coloured += scene.coloured(i);
    }
    CHECK(scene.patch_count() > 100);
    CHECK(coloured == scene.patch_count());
    const Rgb exact = base * (0.5 * (c0 + c1 + c2) / 3.0 + 0.5 * (c0 + c2 + c3) / 3.0);
    CHECK(sum.isApprox(exact, 1e-12));
    // Two-sided: the twin facing -z has the same colour at the same point.
    json two = doc;
    two["materials"][0]["doubleSided"] = true;
    dir.write("two.glb", raybundle::test::glb(two, bin));
    const Scene both = scene_of("two.glb", 0.25);
    const Vec3 x(0.713, 0.271, 0);  // inside a patch, on no edge
    int sides = 0;
    for (std::size_t i = 0; i < both.patch_count(); ++i)
        if (holds(both, i, x)) {
            ++sides;
            CHECK(both.albedo_at(i, x).isApprox(base * interpolated(p0, p1, p2, c0, c1, c2, x), 1e-12));
        }
    CHECK(sides == 2);
    // FLOAT colours past 1 are clamped, with a warning; another type is refused.
    std::string floats = bin.substr(0, 48);
    const std::vector<float> rgb = {1.5, 0, 0, 0, 1, 0, 0, 0, 1, 0.5, 0.5, 0.5};
    floats.append(reinterpret_cast<const char*>(rgb.data()), 48);
    floats.append(bin.substr(64, 12));
    json bright = doc;
    bright["bufferViews"][1]["byteLength"] = 48;
    bright["bufferViews"][2]["byteOffset"] = 96;
    bright["accessors"][1] = {{"bufferView", 1}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}};
    dir.write("bright.glb", raybundle::test::glb(bright, floats));
    const Scene clamped = scene_of("bright.glb", 0.25);
    CHECK(clamped.albedo_at(patch_at(clamped, Vec3(0, 0, 0)), Vec3(0, 0, 0)).isApprox(base * c0, 1e-12));
    REQUIRE(clamped.warnings.size() == 1);
    CHECK_THAT(clamped.warnings[0], Contains("COLOR_0 has values outside [0, 1]") && Contains("clamped"));
    // A base colour factor of 1 with colours below 1 (as Blender exports a colour
    // attribute on the base colour) reflects less than it receives: kept, no warning.
    std::string dimmer = bin;
    for (std::size_t k = 48; k < 64; ++k)
        if (k % 4 != 3) dimmer[k] = static_cast<char>(static_cast<unsigned char>(dimmer[k]) * 200 / 255);
    json white = doc;
    white["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = {1, 1, 1, 1};
    dir.write("white.glb", raybundle::test::glb(white, dimmer));
    const Scene kept = scene_of("white.glb", 0.25);
    CHECK(kept.warnings.empty());
    CHECK(kept.albedo_at(patch_at(kept, p1), p1).isApprox(Rgb(0, 200.0 / 255, 0), 1e-12));
    // -D settings that change neither albedo nor specular keep that base colour of 1.
    const Scene glowing = load_scene((dir.path / "white.glb").string(), {{"materials.paint.emission", "[0.5, 0.5, 0.5]"}});
    const Material& paint = glowing.materials[static_cast<std::size_t>(glowing.find_material("paint"))];
    CHECK(paint.albedo.isApprox(Rgb::Ones()));
    CHECK(paint.emission.isApprox(Rgb::Constant(0.5)));
    CHECK(glowing.albedo_at(patch_at(glowing, p1), p1).isApprox(Rgb(0, 200.0 / 255, 0), 1e-12));
    // The contraction check counts the colours' bound (200/255 here): an albedo of 1.2
    // reflects at most 0.94 and is taken, element by element too.
    const Scene lifted = load_scene((dir.path / "white.glb").string(), {{"materials.paint.albedo[1]", "1.2"}});
    CHECK(lifted.albedo_at(patch_at(lifted, p1), p1).isApprox(Rgb(0, 1.2 * 200.0 / 255, 0), 1e-12));
    CHECK_THROWS_WITH(load_scene((dir.path / "white.glb").string(), {{"materials.paint.albedo[1]", "1.3"}}),
                      Contains("albedo + specular = 1.019") && Contains("in channel g"));
    // Named by an object without colours, such a material would reflect all it receives.
    CHECK_THROWS_WITH(parse_scene(R"({"camera": {"eye": [0.5, 0.5, 2], "target": [0.5, 0.5, 0]},
                                      "objects": [{"mesh": "white.glb"},
                                                  {"triangle": [[0, 0, -1], [1, 0, -1], [0, 1, -1]], "material": "paint"}]})",
                                  "s.json", dir.path.string()),
                      Contains("s.json: materials.paint: albedo + specular = 1 in channel r on objects[1]") &&
                          Contains("which has no vertex colours to dim it"));
    // Mirrored (a negative scale turns the triangles round): the same colour at the
    // mirrored point.
    const Scene mirrored = parse_scene(R"({"camera": {"eye": [-0.5, 0.5, 2], "target": [-0.5, 0.5, 0]}, "patch_size": 0.25,
                                           "objects": [{"mesh": "colours.glb", "scale": [-1, 1, 1]}]})",
                                       "s.json", dir.path.string());
    for (const Vec3& y : {Vec3(0.9, 0.05, 0), Vec3(0.3, 0.7, 0)}) {
        const Vec3 image(-y.x(), y.y(), 0.0);
        CHECK(mirrored.albedo_at(patch_at(mirrored, image), image).isApprox(scene.albedo_at(patch_at(scene, y), y), 1e-12));
    }
    json vec2 = doc;
    vec2["accessors"][1]["type"] = "VEC2";
    dir.write("vec2.glb", raybundle::test::glb(vec2, bin));
    CHECK_THROWS_WITH(scene_of("vec2.glb", 0.25),
                      Contains("meshes[0].primitives[0]: COLOR_0: expected VEC3 or VEC4 of FLOAT, UNSIGNED_BYTE or "
                               "UNSIGNED_SHORT"));
}

TEST_CASE("PLY: red, green, blue per vertex (sRGB) times the object's albedo, and a texture times the colour",
          "[scenes][texture][colour]") {
    TempDir dir;
    dir.write("scan.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n"
              "0 0 0 255 128 0\n1 0 0 0 255 64\n0 1 0 10 20 30\n3 0 1 2\n");
    const Scene scene = parse_scene(R"({"camera": {"eye": [0.3, 0.3, 2], "target": [0.3, 0.3, 0]}, "patch_size": 0.2,
        "materials": {"clay": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [{"mesh": "scan.ply", "material": "clay"}]})",
                                    "s.json", dir.path.string());
    const Rgb c0 = linear(255, 128, 0), c1 = linear(0, 255, 64), c2 = linear(10, 20, 30);
    for (const Vec3& x : {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.2, 0.3, 0)})
        CHECK(scene.albedo_at(patch_at(scene, x), x)
                  .isApprox(0.5 * interpolated(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), c0, c1, c2, x), 1e-12));
    dir.write("half.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
              "0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n");
    dir.write("signed.ply",
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "property char red\nproperty char green\nproperty char blue\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n0 0 0 1 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n3 0 1 2\n");
    CHECK_THROWS_WITH(read_mesh_file((dir.path / "signed.ply").string(), "signed.ply"),
                      Contains("signed.ply: header: vertex colour red is a signed integer"));
    const MeshData half = read_mesh_file((dir.path / "half.ply").string(), "half.ply");
    CHECK(half.colours.empty());
    REQUIRE(half.warnings.size() == 1);
    CHECK_THAT(half.warnings[0], Contains("half.ply: header: vertex colours need all of red, green, blue (found red): "
                                          "not read"));
    // A texture and vertex colours: the texel times the colour, and a patch's mean of
    // that product.
    Scene both;
    Material tiles;
    tiles.name = "tiles";
    tiles.texture = std::make_shared<const Texture>(texture_of(4, 4, sixteen()));
    tiles.tint = Rgb(1, 0.5, 1);
    tiles.albedo = tiles.tint * tiles.texture->mean();
    const int t = both.add_material(tiles);
    const Rgb k0(1, 0.5, 0.25), k1(0.5, 1, 0.5), k2(0.25, 0.5, 1);
    both.add_object({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{{0, 1, 2}}}, t, "quad", -1, {}, {{Uv(0, 1), Uv(1, 1), Uv(1, 0)}},
                    {{k0, k1, k2}});
    both.finalize();
    const Vec3 in_texel((2 + 0.5) / 4, 1.0 - (3 + 0.5) / 4, 0.0);  // texel (2, 3)'s centre
    CHECK(both.albedo_at(0, in_texel)
              .isApprox(tiles.tint * sixteen_at(2, 3) *
                            interpolated(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), k0, k1, k2, in_texel),
                        1e-12));
    Rgb mean = Rgb::Zero();
    const int n = 200;
    int inside = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const Vec3 y((i + 0.5) / n, (j + 0.5) / n, 0.0);
            if (y.y() > y.x()) continue;
            mean += both.albedo_at(0, y), ++inside;
        }
    CHECK(both.albedo_of(0).isApprox(mean / inside, 0.01));
}
