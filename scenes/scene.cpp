#include "scenes/scene.h"

#include "scenes/errors.h"

#include <algorithm>
#include <cmath>

namespace raybundle::scenes {

Scene::Scene() {
    mesh.add_property(material_handle, "material");
    mesh.add_property(object_handle, "object");
}

int Scene::add_object(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                      int material, const std::string& name, int object) {
    return add_object(vertices, triangles, std::vector<int>(triangles.size(), material), name, object);
}

int Scene::add_material(Material m) {
    materials.push_back(std::move(m));
    return static_cast<int>(materials.size()) - 1;
}

int Scene::find_material(const std::string& material_name) const {
    for (std::size_t i = 0; i < materials.size(); ++i)
        if (materials[i].name == material_name) return static_cast<int>(i);
    return -1;
}

int Scene::add_object(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                      const std::vector<int>& triangle_materials, const std::string& name, int object) {
    if (object < 0) {
        object = static_cast<int>(object_names.size());
        object_names.push_back(name.empty() ? "object " + std::to_string(object) : name);
    }
    std::vector<TriMesh::VertexHandle> handles;
    handles.reserve(vertices.size());
    for (const auto& v : vertices) handles.push_back(mesh.add_vertex(to_om(v)));
    for (std::size_t k = 0; k < triangles.size(); ++k) {
        const auto& t = triangles[k];
        auto f = mesh.add_face(handles[t[0]], handles[t[1]], handles[t[2]]);
        if (!f.is_valid()) {
            // Non-manifold input (OpenMesh refuses the face): keep it as a separate triangle.
            f = mesh.add_face(mesh.add_vertex(to_om(vertices[t[0]])), mesh.add_vertex(to_om(vertices[t[1]])),
                              mesh.add_vertex(to_om(vertices[t[2]])));
        }
        mesh.property(material_handle, f) = triangle_materials[k];
        mesh.property(object_handle, f) = object;
    }
    return object;
}

void Scene::finalize() {
    // Drop zero-area triangles (they carry no light and break normals).
    std::size_t dropped = 0;
    mesh.request_face_status();
    mesh.request_edge_status();
    mesh.request_vertex_status();
    for (auto f : mesh.faces()) {
        auto it = mesh.cfv_iter(f);
        const Vec3 a = to_eigen(mesh.point(*it++));
        const Vec3 b = to_eigen(mesh.point(*it++));
        const Vec3 c = to_eigen(mesh.point(*it));
        const double area2 = (b - a).cross(c - a).norm();
        const double scale = std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
        if (!(area2 > 1e-12 * scale)) {
            mesh.delete_face(f, true);
            ++dropped;
        }
    }
    mesh.garbage_collection();
    dropped_degenerate += dropped;

    positions.clear();
    positions.reserve(mesh.n_vertices());
    for (auto v : mesh.vertices()) positions.push_back(to_eigen(mesh.point(v)));

    patches.clear();
    patches.reserve(mesh.n_faces());
    area_sum = 0.0;
    for (auto f : mesh.faces()) {
        Patch p{};
        int k = 0;
        for (auto v : mesh.fv_range(f)) p.v[k++] = v.idx();
        const Vec3& a = positions[p.v[0]];
        const Vec3& b = positions[p.v[1]];
        const Vec3& c = positions[p.v[2]];
        const Vec3 cross = (b - a).cross(c - a);
        p.area = 0.5 * cross.norm();
        p.normal = cross.normalized();
        p.centroid = (a + b + c) / 3.0;
        p.material = mesh.property(material_handle, f);
        p.object = mesh.property(object_handle, f);
        area_sum += p.area;
        patches.push_back(p);
    }
    if (patches.empty()) throw SceneError(name, "", "the scene has no patches");

    normals.assign(positions.size(), Vec3::Zero());
    for (const auto& p : patches)
        for (int v : p.v) normals[v] += p.area * p.normal;
    for (auto& n : normals) n.normalize();

    // Bounding sphere of the patches (vertices no patch uses do not count): centre of
    // the bounding box, radius to the farthest patch vertex.
    Vec3 lo = positions[patches.front().v[0]], hi = lo;
    for (const auto& p : patches)
        for (int v : p.v) {
            lo = lo.cwiseMin(positions[v]);
            hi = hi.cwiseMax(positions[v]);
        }
    center = 0.5 * (lo + hi);
    radius = 0.0;
    for (const auto& p : patches)
        for (int v : p.v) radius = std::max(radius, (positions[v] - center).norm());
}

bool Scene::has_glossy() const {
    return std::any_of(materials.begin(), materials.end(), [](const Material& m) { return m.glossy(); });
}

bool Scene::has_emission() const {
    return std::any_of(materials.begin(), materials.end(), [](const Material& m) { return m.emissive(); });
}

VertexCorners vertex_corners(const Scene& scene) {
    const auto& patches = scene.patch_list();
    VertexCorners vc;
    vc.start.assign(scene.vertex_positions().size() + 1, 0);
    for (const auto& p : patches)
        for (int v : p.v) ++vc.start[v + 1];
    for (std::size_t k = 1; k < vc.start.size(); ++k) vc.start[k] += vc.start[k - 1];
    vc.corners.resize(vc.start.back());
    std::vector<std::size_t> fill(vc.start.begin(), vc.start.end() - 1);
    for (std::size_t i = 0; i < patches.size(); ++i)
        for (int k = 0; k < 3; ++k) vc.corners[fill[patches[i].v[k]]++] = static_cast<std::uint32_t>(3 * i + k);
    return vc;
}

}  // namespace raybundle::scenes
