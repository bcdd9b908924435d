#pragma once
// Reading OBJ, PLY (ASCII and binary) and OFF (ASCII and binary) meshes. The readers
// are the project's own, not OpenMesh IO's: those keep one normal per vertex, skip bad
// faces and short files quietly, trust a header's counts until an allocation fails and
// crash or never return on some malformed headers. Here every count is checked against
// the bytes left before anything is allocated for it, and any fault is one line.
#include "scenes/scene.h"

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace raybundle::scenes {

struct MeshData {
    std::vector<Vec3> vertices;
    std::vector<std::array<int, 3>> triangles;  // polygons are triangulated
    // The file's normals at every triangle's corners (unit), or empty when it has none.
    // A zero vector: no normal at that corner (an OBJ face without them).
    std::vector<std::array<Vec3, 3>> normals;
    // The file's texture coordinates at every triangle's corners, as (s, t) with t down
    // from the image's top (an OBJ's vt v is 1 - t), or empty when it has none (a
    // triangle without them in a file with some: NaN).
    std::vector<std::array<Uv, 3>> uvs;
    // The file's vertex colours at every triangle's corners (linear, in [0, 1]: they
    // multiply the albedo), or empty when it has none (a triangle without them in a file
    // with some: NaN). glTF's COLOR_0; a PLY's red, green, blue.
    std::vector<std::array<Rgb, 3>> colours;
    // OBJ only (empty for PLY and OFF, and for an OBJ without `usemtl`, `o` or `g`):
    // each triangle's material, an index into `materials` (the names `usemtl` gives, in
    // order of first use; -1 before the first), and its group, an index into `groups`
    // (the names of `o` and `g`; -1 before the first); the MTL files of its `mtllib`
    // lines (as written: relative to the OBJ's folder), in order.
    std::vector<int> triangle_material, triangle_group;
    std::vector<std::string> materials, groups, material_libraries;
    std::vector<long> material_lines;  // OBJ: the line of each material's first `usemtl`
    // glTF only: the file's own materials (mapped: docs/scene-format.md), one per name
    // of `materials`; its KHR_lights_punctual point, spot and directional lights and its first camera (in
    // world space); what was read otherwise or not at all, one line each (naming the
    // file); and the files it read besides itself (buffers, textures).
    std::vector<Material> material_defs;
    std::vector<PointLight> point_lights;
    std::vector<DirectionalLight> directional_lights;
    // The file's asset.generator names Blender, and it places lights: Blender's default
    // ("Standard") lighting export writes them 683 times the scale of its emission.
    bool blender_lights = false;
    std::optional<Camera> camera;
    std::vector<std::string> warnings, resources;
};

// A material of an MTL file, as written (scenes/loader.cpp maps it: docs/scene-format.md).
struct MtlMaterial {
    std::string name;
    long line = 0;               // of its `newmtl`
    Rgb kd = Rgb::Constant(0.8);  // diffuse reflectance (0.8 where the file gives none)
    Rgb ke = Rgb::Zero();         // emission
    Rgb ks = Rgb::Zero();         // specular reflectance
    double ns = 0.0;              // specular exponent
    int illum = -1;               // illumination model (-1: not given)
    std::string map_kd;           // the diffuse texture's file, as written (its options passed over)
    std::string map_kd_last;      // the last word of the statement (a name after an unknown option)
    // map_Kd's -o and -s options (u and v; w ignored): the texture read at offset + scale
    // * (u, v); -clamp on: clamped at its edges, not repeated.
    Uv map_kd_offset = Uv::Zero(), map_kd_scale = Uv::Ones();
    bool map_kd_clamp = false;
    // The file was written by Blender (its first comment says so): Ks is its Principled
    // BSDF's "specular" (0.5 by default), whose reflectance at normal incidence is 0.08 Ks.
    bool blender = false;
};
// The materials of an MTL file (`shown` names it in errors). Throws SceneError naming
// the file and line: a value before the first `newmtl`, a malformed or non-finite
// number, a negative colour or exponent, a material defined twice. Other statements
// (Ka, d, Tr, Ni, Tf, the other maps) are read past.
std::vector<MtlMaterial> parse_mtl(std::string_view content, const std::string& shown);

// The scene's material of every triangle of a mesh that brings its own (an OBJ object
// without "material": its usemtl names). A name of the scene file's own materials (the
// first `scene_materials` of the scene) is the scene's; else the first definition in the
// mesh's MTL files (its mtllib lines, relative to `path`'s folder), or the glTF file's,
// is the scene's material of that name where an earlier mesh brought the same values,
// and otherwise added to the scene, as "NAME (shown)" with a warning where an earlier
// mesh's of that name differs (Blender calls every default material "Material"). MTL:
// Kd the albedo, Ke the emission, Ks and Ns the Phong lobe where illum asks for
// highlights (not 0 or 1; Ns 0 joins the albedo, Blender's Ks is a dielectric's Fresnel
// reflection and no lobe), both scaled down where Kd + Ks reaches 1; a PNG map_Kd
// is the albedo by its mean linear colour. A scaled material, an illum above 2 and a
// texture (read as its mean, or not read) are lines of scene.warnings; the MTL files
// and textures join scene.files. What an asset lacks is 0.8 grey with a warning, as
// Blender imports it: a missing MTL file, a name no MTL file defines, faces before the
// first usemtl or an OBJ without any (the material "default"). `edits` (the scene's -D
// settings of some values of a material, scenes/loader.cpp) lays them over a brought
// material of their name before it is shared or renamed, and again over one renamed
// "NAME (shown)" where the settings name that; it returns whether it changed it. A
// mesh's warnings are given once however often it is placed. Throws SceneError(shown,
// where): an unreadable or malformed MTL file, emission past 1e15.
using MaterialEdits = std::function<bool(Material& brought)>;
std::vector<int> mesh_materials(Scene& scene, std::size_t scene_materials, const MeshData& data, const std::string& path,
                                const std::string& shown, const std::string& where, const MaterialEdits& edits = {});
// The -D key of a material of the scene: "materials.NAME", or materials["NAME"] where the
// name holds a dot, a bracket or a quote ("Material.001", "Material (b.obj)").
std::string material_setting(const std::string& name);

// The most triangles a mesh file may give once its instances are placed (a glTF node
// tree can place one mesh many times): five times what the patch limit lets through.
inline constexpr std::size_t kMaxMeshTriangles = 100'000'000;

// Reads `path` (shown as `shown` in errors). Throws SceneError naming the file and
// the offending line or count: missing or unreadable file, not a regular file (a
// directory, FIFO or device), unknown extension, a malformed header or count, a face
// with fewer than 3 corners, a polygon that crosses itself or is not planar
// (triangulate_polygon), a face index out of range, a file shorter than its header
// promises, non-finite coordinates, a bad normal (non-finite, an OBJ normal index out
// of range, an OBJ face with normals at some corners only, a PLY vertex with some of
// nx, ny, nz).
// Normals: OBJ `vn` (faces `v//vn`, `v/vt/vn`) and the PLY vertex properties nx, ny, nz;
// one of zero length (exporters write them at degenerate faces) is a zero normal in
// MeshData (its corners computed) and a warning. An OBJ statement ending in `\` goes
// on in the next line.
MeshData read_mesh_file(const std::string& path, const std::string& shown);
// glTF 2.0 (.gltf, .glb; scenes/mesh_gltf.cpp): the triangles of the default scene's
// nodes in world space, its materials, point, spot and directional lights and first
// camera. Throws SceneError naming the file and the object: malformed JSON or GLB, a missing buffer,
// an accessor out of its buffer's range, an index out of range, a node that is its own
// ancestor or has two parents, a required extension it cannot read, more than
// `max_triangles` triangles.
//
// The same from the file's bytes, `format` "obj", "ply", "off", "gltf" or "glb". A
// glTF read from bytes has no folder: a buffer or image in another file is refused.
MeshData parse_mesh(std::string_view content, const std::string& format, const std::string& shown,
                    std::size_t max_triangles = kMaxMeshTriangles);

// A polygon's triangles, as triples of positions in `corners` (counter-clockwise
// seen from the side its corners turn counter-clockwise around, as the fan keeps
// them): a fan from the first corner when the polygon is convex, ear clipping when it
// is concave (a fan would fold over). Throws SceneError(shown, where) for a polygon
// that crosses itself, or whose corners lie off its plane (the least-squares plane's
// normal by Newell's method) by more than `max_bend` times its longest edge: its
// surface would depend on how it is cut. A polygon of (nearly) zero area is fanned:
// its triangles are dropped on load with the other zero-area ones.
std::vector<std::array<int, 3>> triangulate_polygon(const std::vector<Vec3>& corners, double max_bend,
                                                    const std::string& shown, const std::string& where);
// The bend mesh files' polygons may have: a tenth of the longest edge (quads of
// organic models bend a few percent; a corner of the wrong vertex bends by ~1).
inline constexpr double kMeshPolygonBend = 0.1;

// The largest mesh file read (4 GiB: some 100 million triangles, five times what the
// patch limit lets through) and the largest scene file (64 MiB).
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{4} << 30;
inline constexpr std::uintmax_t kMaxSceneFileBytes = std::uintmax_t{64} << 20;

// The whole of `path` as bytes, refused (SceneError naming `shown`, the file as the
// user wrote it) unless it is a regular file of at most `max_bytes`: a directory, a
// FIFO or a device (/dev/zero) would block, never end or eat memory. `kind` names the
// file in messages ("mesh file", "scene file").
std::string read_input_file(const std::string& path, const std::string& shown, const std::string& kind,
                            std::uintmax_t max_bytes);

}  // namespace raybundle::scenes
