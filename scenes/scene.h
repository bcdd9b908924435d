#pragma once
// The scene model: one-sided triangular patches on an OpenMesh TriMesh, their
// materials, the camera, and flat per-patch arrays derived once for the inner loops.
#include "scenes/buffer.h"
#include "scenes/texture.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <array>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace raybundle::scenes {

using Vec3 = Eigen::Vector3d;
using Rgb = Eigen::Array3d;
using Uv = Eigen::Vector2d;  // texture coordinates (s, t)

struct MeshTraits : public OpenMesh::DefaultTraits {
    using Point = OpenMesh::Vec3d;
    using Normal = OpenMesh::Vec3d;
};
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<MeshTraits>;

// Diffuse albedo plus an optional glossy lobe: the physically plausible modified
// Phong BRDF  f = albedo/pi + specular (n+2)/(2 pi) cos^n(alpha). Emission is a
// radiance, emitted on the front side only.
struct Material {
    std::string name;
    Rgb albedo = Rgb::Zero();
    Rgb emission = Rgb::Zero();
    Rgb specular = Rgb::Zero();
    double exponent = 0.0;
    // Lit (and emitting) on both sides: the loader gives every triangle of such a
    // material a twin facing the other way, at the same place, and the renderer's rays
    // meet whichever of the two faces them.
    bool two_sided = false;
    // An asset's texture of the albedo: at a point of a patch with texture coordinates
    // the albedo is tint times the texture's colour there (Scene::albedo_at), and a
    // patch's is tint times the texture's mean over the patch (Scene::albedo_of);
    // `albedo` is tint times the mean over the whole texture (what a patch without
    // texture coordinates reflects, and what summaries show).
    std::shared_ptr<const Texture> texture = nullptr;
    Rgb tint = Rgb::Ones();
    // The texture coordinates the texture reads: uv_offset + uv_linear (s, t) of the
    // faces' (an MTL's map_Kd -o and -s).
    Eigen::Matrix2d uv_linear = Eigen::Matrix2d::Identity();
    Uv uv_offset = Uv::Zero();
    // The most the vertex colours of its triangles multiply the albedo by (a glTF
    // material whose every triangle has COLOR_0): what the energy checks count, so that
    // a base colour of 1 dimmed by colours below 1 is kept. 1: no such bound (the loader
    // refuses a patch without colours that would then reflect all it receives).
    Rgb colour_bound = Rgb::Ones();

    bool glossy() const { return (specular > 0.0).any(); }
    bool emissive() const { return (emission > 0.0).any(); }
};

struct Camera {
    Vec3 eye{0, 0, 1};
    Vec3 target{0, 0, 0};
    Vec3 up{0, 1, 0};
    double fov_y = 40.0;  // degrees, vertical
    int width = 512;
    int height = 512;
};

// A point light, isotropic or a spot; intensity in W/sr (radiant intensity per
// channel). Handled by the first shot: its direct effect is computed exactly, with
// shadows.
struct PointLight {
    Vec3 position = Vec3::Zero();
    Rgb intensity = Rgb::Zero();  // radiant intensity (W/sr); a spot's on its axis
    // A spot: its axis (unit), full intensity within the inner cone, none past the outer
    // one, between them the square of the linear ramp in the cosine (glTF's
    // KHR_lights_punctual). A zero axis: the light is isotropic.
    Vec3 axis = Vec3::Zero();
    double cos_inner = 1.0, cos_outer = -1.0;

    bool spot() const { return axis != Vec3::Zero(); }
    // The fraction of `intensity` the light sends along the unit direction w.
    double falloff(const Vec3& w) const {
        if (!spot()) return 1.0;
        const double c = axis.dot(w);
        if (c >= cos_inner) return 1.0;
        if (c <= cos_outer) return 0.0;
        const double t = (c - cos_outer) / (cos_inner - cos_outer);
        return t * t;
    }
};

// A directional light (a sun): parallel light travelling along `direction` (unit),
// `irradiance` on a surface that faces it (W/m^2 per channel; glTF's lux). Handled
// by the first shot, as a point light is.
struct DirectionalLight {
    Vec3 direction{0, -1, 0};
    Rgb irradiance = Rgb::Zero();
    // Where it was given, for messages: "directional_lights[0]" (the scene file's key),
    // or "model.gltf: light 'Sun'".
    std::string name;
};

// Light from directions no patch covers. "constant": the same radiance from every
// direction above the horizon (up . w > 0). "overcast": the CIE standard overcast
// sky, L(theta) = radiance (1 + 2 cos theta) / 3 with theta the angle from the
// zenith: "radiance" at the zenith, a third of it at the horizon. Below the horizon
// the sky is black.
struct Sky {
    enum class Model { constant, overcast };
    Rgb radiance = Rgb::Zero();
    Vec3 up{0, 1, 0};  // unit
    Model model = Model::constant;

    // Sky radiance arriving along the travel direction d (light moving along d, so it
    // comes from the sky direction -d).
    Rgb arriving_along(const Vec3& d) const {
        const double c = -up.dot(d);  // cosine between the sky direction and the zenith
        if (c <= 0.0) return Rgb::Zero();
        return model == Model::constant ? radiance : radiance * ((1.0 + 2.0 * c) / 3.0);
    }
};

// A patch with everything the inner loops need, in one cache-friendly record.
struct Patch {
    int v[3];       // vertex indices into Scene::positions
    Vec3 normal;    // unit, front side
    Vec3 centroid;
    double area;
    int material;
    int object;     // index into Scene::object_names
};

class Scene {
public:
    std::string name;             // the built-in name or the scene file
    TriMesh mesh;                 // topology, IO and subdivision
    std::vector<Material> materials;
    Camera camera;
    std::vector<PointLight> point_lights;
    std::vector<DirectionalLight> directional_lights;
    std::optional<Sky> sky;
    std::optional<double> exact_radiance;  // known analytic answer (every patch, every channel)
    // For a closed scene with one albedo a everywhere (and exact_radiance set): the
    // exact answer of a solver truncated after D bounces is exact (1 - a^(D+1)).
    std::optional<double> homogeneous_albedo;
    std::size_t dropped_degenerate = 0;    // zero-area triangles removed on load
    std::size_t welded_vertices = 0;       // mesh vertices merged with one at the same place
    std::vector<std::size_t> dropped_by_object;  // the same per object (index as object_names)
    // "dropped 3 zero-area triangles (Floor 1, Lamp 2)"; empty where none were.
    std::string dropped_summary() const;
    // The files it was read from (the scene file, then its meshes), so that no output
    // of a run overwrites one of them (render::check_outputs).
    std::vector<std::string> files;
    // What loading read otherwise than written, or left out (an MTL's texture, a
    // material scaled down), one line each: shown as warnings by `check` and `solve`.
    std::vector<std::string> warnings;
    // Patches cut along the lines where other surfaces touch them (scenes/contacts.h):
    // the lines, the edges split, and the contact edges marked.
    std::size_t contact_lines = 0, contact_splits = 0, contact_edges = 0;
    // How the patches were refined, one line for the run's record: the patch size and
    // where it came from (the scene's, a built-in's default, the automatic 1/25 of the
    // scene's largest extent, or none: the patches as modelled).
    std::string refinement;

    // The objects the patches came from (a mesh file, a quad, a built-in part), for
    // messages; every patch knows its object.
    std::vector<std::string> object_names;

    // Per object, the crease angle in degrees of the shading normals finalize()
    // computes for it (see corner_normal_handle); 0 keeps the patches flat.
    static constexpr double default_crease_angle = 30.0;
    std::vector<double> crease_angles;

    // Per-face material and object index, kept on the mesh so that subdivision copies them.
    OpenMesh::FPropHandleT<int> material_handle;
    OpenMesh::FPropHandleT<int> object_handle;
    // The shading normal of every patch corner, on the halfedge of the face that ends
    // at the corner's vertex, so that subdivision carries it (it gives the corners of a
    // split edge's new vertex the normalised mean of the edge's two corner normals in
    // each face). A zero vector (the value a new halfedge gets) marks a corner without
    // one: finalize() computes it.
    OpenMesh::HPropHandleT<std::array<double, 3>> corner_normal_handle;
    // Edges on a line where another surface touches (scenes/contacts.h): the radiance
    // may jump across them, so the flat arrays give the patches on either side
    // vertices of their own there (finalize()), and nothing that averages over a
    // vertex's patches (smooth shading, the linear basis's nodes) mixes the two sides.
    // Subdivision keeps the mark on both halves of a split edge.
    OpenMesh::EPropHandleT<bool> contact_edge_handle;
    // Texture coordinates and vertex colours. A textured triangle as added (or one with
    // vertex colours) gives its plane's affine maps from a point to (s, t) and to the
    // colour; every patch cut from it (refinement, contact lines: they copy face
    // properties) keeps the maps' index, so that its coordinates and colour are exact at
    // every point without being carried through the splits. -1: none.
    struct TextureMap {
        Vec3 origin = Vec3::Zero();
        // (s, t) = at_origin + linear (x - origin); NaN at_origin: no coordinates.
        Eigen::Matrix<double, 2, 3> linear = Eigen::Matrix<double, 2, 3>::Zero();
        Uv at_origin = Uv::Constant(std::numeric_limits<double>::quiet_NaN());
        // The vertex colour (linear, in [0, 1]: what multiplies the albedo) =
        // colour_at_origin + colour_linear (x - origin); NaN colour_at_origin: none.
        Eigen::Matrix3d colour_linear = Eigen::Matrix3d::Zero();
        Rgb colour_at_origin = Rgb::Constant(std::numeric_limits<double>::quiet_NaN());

        bool has_uv() const { return at_origin.allFinite(); }
        bool has_colour() const { return colour_at_origin.allFinite(); }
        Uv operator()(const Vec3& x) const { return at_origin + linear * (x - origin); }
        // Clamped: a point off the triangle (a pixel's point a rounding outside) stays in range.
        Rgb colour(const Vec3& x) const {
            return (colour_at_origin + (colour_linear * (x - origin)).array()).max(0.0).min(1.0);
        }
    };
    std::vector<TextureMap> texture_maps;
    OpenMesh::FPropHandleT<int> texture_map_handle;

    Scene();

    // Adds one object (returns its index): vertices shared by its triangles (so that
    // subdivision stays conforming), all with one material. Front sides are
    // counter-clockwise. With `object` >= 0 the triangles join that object instead.
    // `normals`, when not empty, gives every triangle's corner normals (the file's; they
    // are normalised, and a zero vector leaves that corner to finalize()).
    // `uvs`, when not empty, gives every triangle's corner texture coordinates (s, t: see
    // Texture::at; NaN where a triangle has none): a triangle of a textured material
    // keeps them as a TextureMap. `colours`, when not empty, gives every triangle's
    // corner vertex colours (linear, clamped to [0, 1]; NaN where a triangle has none),
    // which multiply its albedo: kept as a TextureMap too.
    int add_object(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles, int material,
                   const std::string& name = "", int object = -1,
                   const std::vector<std::array<Vec3, 3>>& normals = {}, const std::vector<std::array<Uv, 3>>& uvs = {},
                   const std::vector<std::array<Rgb, 3>>& colours = {});
    // The same with one material per triangle.
    int add_object(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                   const std::vector<int>& materials, const std::string& name = "", int object = -1,
                   const std::vector<std::array<Vec3, 3>>& normals = {}, const std::vector<std::array<Uv, 3>>& uvs = {},
                   const std::vector<std::array<Rgb, 3>>& colours = {});
    // Adds a material and returns its index.
    int add_material(Material m);
    // The index of the material called name, or -1.
    int find_material(const std::string& name) const;

    // Derives the flat arrays below from the mesh (drops zero-area triangles first, then
    // computes the corner normals that are missing). Call after the mesh changes;
    // everything downstream reads only the flat arrays. Faces on `threads` threads; the
    // same result for any count.
    void finalize(int threads = 1);

    std::size_t patch_count() const { return patches.size(); }
    const Buffer<Patch>& patch_list() const { return patches; }
    // The patches' vertices: the mesh's, with one copy per side of a contact edge.
    const std::vector<Vec3>& vertex_positions() const { return positions; }
    // Per patch, the unit shading normals at its corners v[0], v[1], v[2]: the file's,
    // or the angle-weighted mean of the normals of the patches around the corner's
    // vertex that lie within the object's crease angle of the patch's own. A corner
    // normal within 1.4e-6 rad of the patch normal is the patch normal, so flat
    // surfaces stay exactly flat.
    const Buffer<std::array<Vec3, 3>>& corner_normals() const { return shading_normals; }
    // The shading normal at the point (1 - b1 - b2) v[0] + b1 v[1] + b2 v[2] of a patch
    // (the barycentric weights of RayHit and GSample): the corner normals interpolated
    // and normalised, and turned over when that makes it face away from the patch
    // normal, so it is never on the back of the patch. The patch normal still decides
    // which side is the front.
    Vec3 shading_normal(std::size_t patch, double b1, double b2) const;
    const Material& material_of(std::size_t patch) const { return materials[patches[patch].material]; }
    // The albedo of a patch: its material's, or for a textured patch the tint times the
    // texture's mean over it (finalize()), times its vertex colours' where it has them.
    // What the solver reflects.
    const Rgb& albedo_of(std::size_t patch) const {
        return patch_albedo.empty() ? material_of(patch).albedo : patch_albedo[patch];
    }
    // The albedo at the point x of a patch: the texture's there where it is textured,
    // else its material's, times the vertex colour there where it has them. What an
    // image shows.
    Rgb albedo_at(std::size_t patch, const Vec3& x) const;
    // The material at the point x of a patch: its own, or where it is textured a copy in
    // `scratch` (its name left out) with albedo_at(patch, x).
    const Material& material_at(std::size_t patch, const Vec3& x, Material& scratch) const;
    // The material of a patch as the solver reflects with it: its own, or where it is
    // textured a copy in `scratch` (its name left out) with albedo_of(patch).
    const Material& patch_material(std::size_t patch, Material& scratch) const;
    // Some patch has a texture or vertex colours (albedo_at differs from albedo_of somewhere).
    bool textured() const { return !patch_albedo.empty(); }
    // The patch has vertex colours.
    bool coloured(std::size_t patch) const {
        return !patch_texture_map.empty() && patch_texture_map[patch] >= 0 &&
               texture_maps[static_cast<std::size_t>(patch_texture_map[patch])].has_colour();
    }

    Vec3 bounds_center() const { return center; }
    double bounds_radius() const { return radius; }
    double total_area() const { return area_sum; }
    bool has_glossy() const;
    bool has_emission() const;
    // Point, spot or directional lights: lights without area, which the first shot takes.
    bool has_punctual_lights() const { return !point_lights.empty() || !directional_lights.empty(); }

private:
    Buffer<Patch> patches;  // filled on the threads (scenes/buffer.h)
    std::vector<Vec3> positions;
    Buffer<std::array<Vec3, 3>> shading_normals;
    // Where some patch is textured or coloured, per patch: its texture map (-1: none) and albedo.
    std::vector<int> patch_texture_map;
    std::vector<Rgb> patch_albedo;
    Vec3 center = Vec3::Zero();
    double radius = 0.0;
    double area_sum = 0.0;

    void compute_missing_normals(int threads);
    void compute_albedos(int threads);
    void drop_degenerate(int object);  // counts one zero-area triangle of `object` dropped
};

// The patch corners around every vertex, as a compressed row list: the corners
// 3 i + k (patch i, its corner k) at vertex v are corners[start[v] .. start[v + 1]),
// in patch order.
struct VertexCorners {
    std::vector<std::size_t> start;
    std::vector<std::uint32_t> corners;
};
VertexCorners vertex_corners(const Scene& scene);

// The outline of some patches of one plane, all of one orientation (a light, a group
// of emitters): their directed edges (vertex indices, each patch's corners in order)
// less the reverse edges (an edge two of them share cancels), as (from, to) pairs.
// Edges that run straight on through a vertex where nothing else meets are one edge
// (a refined panel's rectangle is 4 edges, not hundreds): a sum over the outline, such
// as Lambert's, is the same, since the angles that the parts of a straight edge
// subtend add up. In order of each joined edge's first vertex, then its second.
std::vector<std::pair<int, int>> plane_outline(const Scene& scene, const std::vector<std::uint32_t>& patches);

inline Vec3 to_eigen(const OpenMesh::Vec3d& p) { return {p[0], p[1], p[2]}; }
inline OpenMesh::Vec3d to_om(const Vec3& p) { return {p.x(), p.y(), p.z()}; }
inline Vec3 to_eigen(const std::array<double, 3>& n) { return {n[0], n[1], n[2]}; }
inline std::array<double, 3> to_array(const Vec3& n) { return {n.x(), n.y(), n.z()}; }

}  // namespace raybundle::scenes
