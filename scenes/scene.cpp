#include "scenes/scene.h"

#include "scenes/buffer.h"
#include "scenes/errors.h"
#include "scenes/threads.h"

#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <map>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

namespace raybundle::scenes {

Scene::Scene() {
    mesh.add_property(material_handle, "material");
    mesh.add_property(object_handle, "object");
    mesh.add_property(corner_normal_handle, "corner normal");
    mesh.add_property(contact_edge_handle, "contact edge");
    mesh.add_property(texture_map_handle, "texture map");
}

namespace {

// The R2 sequence's steps (1/g, 1/g^2, g the plastic number): points k of the unit
// square at frac(0.5 + k kR2), spread evenly for every count.
constexpr double kR2[2] = {0.75487766624669276005, 0.56984029099805326591};

// No area to the precision of its size (finalize()'s and add_object()'s test), the same
// answer whichever corner comes first: measured from the least corner (a triangle at
// the threshold is not kept by one and dropped by the other).
bool zero_area(Vec3 a, Vec3 b, Vec3 c) {
    const auto less = [](const Vec3& p, const Vec3& q) {
        return std::lexicographical_compare(p.data(), p.data() + 3, q.data(), q.data() + 3);
    };
    if (less(b, a)) std::swap(a, b);
    if (less(c, a)) std::swap(a, c);
    if (less(c, b)) std::swap(b, c);
    const double area2 = (b - a).cross(c - a).norm();
    const double scale = std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
    return !(area2 > 1e-12 * scale);
}

// The affine map from the plane of the triangle (a, b, c) to texture coordinates that
// gives its corners theirs: (s, t) = uv0 + [uv1 - uv0, uv2 - uv0] (b1, b2), with
// (b1, b2) the point's barycentric weights of b and c: with n = e1 x e2, x - a = b1 e1 +
// b2 e2 gives b1 = (x - a) . (e2 x n) / |n|^2 and b2 = (x - a) . (n x e1) / |n|^2 (a
// point off the plane goes to its foot on it). Through the cross product, not the
// edges' Gram determinant, which cancels to noise on the slivers add_object keeps.
// The same weights give the vertex colours' map.
Eigen::Matrix<double, 2, 3> barycentric_weights(const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 e1 = b - a, e2 = c - a, n = e1.cross(e2);
    const double nn = n.squaredNorm();
    Eigen::Matrix<double, 2, 3> weights;
    weights.row(0) = (e2.cross(n) / nn).transpose();
    weights.row(1) = (n.cross(e1) / nn).transpose();
    return weights;
}

void map_uvs(Scene::TextureMap& map, const Eigen::Matrix<double, 2, 3>& weights, const std::array<Uv, 3>& uv) {
    Eigen::Matrix2d edges;
    edges.col(0) = uv[1] - uv[0];
    edges.col(1) = uv[2] - uv[0];
    map.linear = edges * weights;
    map.at_origin = uv[0];
}

void map_colours(Scene::TextureMap& map, const Eigen::Matrix<double, 2, 3>& weights, const std::array<Rgb, 3>& colour) {
    Eigen::Matrix<double, 3, 2> edges;
    edges.col(0) = (colour[1] - colour[0]).matrix();
    edges.col(1) = (colour[2] - colour[0]).matrix();
    map.colour_linear = edges * weights;
    map.colour_at_origin = colour[0];
}

}  // namespace

int Scene::add_object(const std::vector<Vec3>& vertices, const std::vector<std::array<int, 3>>& triangles,
                      int material, const std::string& object_name, int object,
                      const std::vector<std::array<Vec3, 3>>& normals, const std::vector<std::array<Uv, 3>>& uvs,
                      const std::vector<std::array<Rgb, 3>>& colours) {
    return add_object(vertices, triangles, std::vector<int>(triangles.size(), material), object_name, object, normals,
                      uvs, colours);
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
                      const std::vector<int>& triangle_materials, const std::string& object_name, int object,
                      const std::vector<std::array<Vec3, 3>>& normals, const std::vector<std::array<Uv, 3>>& uvs,
                      const std::vector<std::array<Rgb, 3>>& colours) {
    if (!normals.empty() && normals.size() != triangles.size())
        throw std::invalid_argument("add_object: " + std::to_string(normals.size()) + " corner normal triples for " +
                                    std::to_string(triangles.size()) + " triangles");
    if (!uvs.empty() && uvs.size() != triangles.size())
        throw std::invalid_argument("add_object: " + std::to_string(uvs.size()) + " texture coordinate triples for " +
                                    std::to_string(triangles.size()) + " triangles");
    if (!colours.empty() && colours.size() != triangles.size())
        throw std::invalid_argument("add_object: " + std::to_string(colours.size()) + " vertex colour triples for " +
                                    std::to_string(triangles.size()) + " triangles");
    const bool made = object < 0;  // else the twins of `object` (two-sided materials)
    if (object < 0) {
        object = static_cast<int>(object_names.size());
        object_names.push_back(object_name.empty() ? "object " + std::to_string(object) : object_name);
    }
    if (crease_angles.size() < object_names.size()) crease_angles.resize(object_names.size(), default_crease_angle);
    std::vector<TriMesh::VertexHandle> handles;
    handles.reserve(vertices.size());
    for (const auto& v : vertices) handles.push_back(mesh.add_vertex(to_om(v)));
    // Triangles kept apart from the others, by why OpenMesh refused them: an edge a
    // neighbour already runs the same way (one of the two is wound the wrong way round),
    // an edge two others already share, or a corner whose fan is closed.
    std::size_t flipped = 0, crowded = 0, pinched = 0;
    // A triangle given twice, the same corners the same way round (an exporter's slip:
    // the "bottom" faces of the boxes of the Cornell box OBJ in McGuire's archive
    // repeat their right and back faces), would put two patches in one place facing
    // one way, of which every visibility map sees one only: the other would stay dark
    // in the solved field, and rays meeting it would read that. The copy is dropped.
    // (The same corners the other way round are a two-sided sheet, and stay.)
    std::set<std::array<std::array<double, 3>, 3>> given;
    std::size_t twice = 0;
    for (std::size_t k = 0; k < triangles.size(); ++k) {
        const auto& t = triangles[k];
        // A corner given twice (f 4 4 3): no area, and OpenMesh cannot make the face;
        // three corners on a line: no area either, and joined to its neighbours it would
        // run their edges the same way as they do (finalize() would drop it later, after
        // its neighbours were kept apart for it). Counted once: not again in a two-sided
        // material's twin (made with its object).
        const bool repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
        if (repeated || zero_area(vertices[t[0]], vertices[t[1]], vertices[t[2]])) {
            if (made) drop_degenerate(object);
            continue;
        }
        std::array<std::array<double, 3>, 3> key;
        int first = 0;  // the corners from the least one on: one key for each rotation
        for (int c = 1; c < 3; ++c)
            if (to_array(vertices[t[c]]) < to_array(vertices[t[first]])) first = c;
        for (int c = 0; c < 3; ++c) key[c] = to_array(vertices[t[(first + c) % 3]]);
        if (!given.insert(key).second) {
            ++twice;
            continue;
        }
        std::array<TriMesh::VertexHandle, 3> corner = {handles[t[0]], handles[t[1]], handles[t[2]]};
        // OpenMesh prints "complex edge" where it refuses a face: said once below instead.
        omerr().disable();
        auto f = mesh.add_face(corner[0], corner[1], corner[2]);
        omerr().enable();
        if (!f.is_valid()) {
            // Non-manifold input (OpenMesh refuses the face): keep it as a separate triangle.
            bool same_way = false, shared = false;
            // The back of a sheet whose front is there (an export's two-sided surface,
            // welded): kept apart as before welding, no warning.
            const auto front = mesh.find_halfedge(corner[1], corner[0]);
            const bool sheet = front.is_valid() && !mesh.is_boundary(front) &&
                               mesh.to_vertex_handle(mesh.next_halfedge_handle(front)) == corner[2];
            for (int c = 0; c < 3; ++c) {
                const auto h = mesh.find_halfedge(corner[c], corner[(c + 1) % 3]);
                const auto back = mesh.find_halfedge(corner[(c + 1) % 3], corner[c]);
                const bool used = h.is_valid() && !mesh.is_boundary(h);
                const bool used_back = back.is_valid() && !mesh.is_boundary(back);
                shared = shared || (used && used_back);
                same_way = same_way || used;
            }
            if (!sheet) ++(shared ? crowded : same_way ? flipped : pinched);
            for (int c = 0; c < 3; ++c) corner[c] = mesh.add_vertex(to_om(vertices[t[c]]));
            f = mesh.add_face(corner[0], corner[1], corner[2]);
        }
        mesh.property(material_handle, f) = triangle_materials[k];
        mesh.property(object_handle, f) = object;
        const auto m = static_cast<std::size_t>(triangle_materials[k]);
        int map = -1;
        const bool has_uvs = !uvs.empty() && uvs[k][0].allFinite() && uvs[k][1].allFinite() && uvs[k][2].allFinite() &&
                             m < materials.size() && materials[m].texture;
        const bool has_colours = !colours.empty() && colours[k][0].allFinite() && colours[k][1].allFinite() &&
                                 colours[k][2].allFinite();
        if (has_uvs || has_colours) {
            map = static_cast<int>(texture_maps.size());
            TextureMap maps;
            maps.origin = vertices[t[0]];
            const auto weights = barycentric_weights(vertices[t[0]], vertices[t[1]], vertices[t[2]]);
            if (has_uvs) {
                map_uvs(maps, weights, uvs[k]);
                maps.linear = materials[m].uv_linear * maps.linear;
                maps.at_origin = materials[m].uv_offset + materials[m].uv_linear * maps.at_origin;
            }
            if (has_colours)
                map_colours(maps, weights,
                            {colours[k][0].max(0.0).min(1.0), colours[k][1].max(0.0).min(1.0), colours[k][2].max(0.0).min(1.0)});
            texture_maps.push_back(maps);
        }
        mesh.property(texture_map_handle, f) = map;
        for (auto h : mesh.fh_range(f)) {
            Vec3 n = Vec3::Zero();
            if (!normals.empty())
                for (int c = 0; c < 3; ++c)
                    if (mesh.to_vertex_handle(h) == corner[c] && normals[k][c].norm() > 0.0)
                        n = normals[k][c].normalized();
            mesh.property(corner_normal_handle, h) = to_array(n);
        }
    }
    if (twice > 0)
        warnings.push_back(object_names[static_cast<std::size_t>(object)] + ": " + std::to_string(twice) +
                           (twice == 1 ? " triangle" : " triangles") +
                           " given twice (the same corners, the same way round): the copies dropped, the first "
                           "one's material kept");
    const std::string& named = object_names[static_cast<std::size_t>(object)];
    auto triangles_text = [](std::size_t n) { return std::to_string(n) + (n == 1 ? " triangle" : " triangles"); };
    if (flipped > 0)
        warnings.push_back(named + ": " + triangles_text(flipped) +
                           " with an edge a neighbour runs the same way (one of them wound the wrong way round?): "
                           "kept as separate triangles, their edges not shared");
    if (crowded > 0)
        warnings.push_back(named + ": " + triangles_text(crowded) +
                           " on edges two others already share (non-manifold): kept as separate triangles");
    if (pinched > 0)
        warnings.push_back(named + ": " + triangles_text(pinched) +
                           " at corners whose triangles already close around them (non-manifold): kept as separate "
                           "triangles");
    return object;
}

// Every corner normal still zero (none given) becomes the angle-weighted mean of the
// normals of the patches around the corner's vertex within the object's crease angle
// of the patch's own normal (the patch itself always counts). Angle weights (Thuermer
// and Wuethrich) do not depend on how a surface is cut into triangles: a quad split in
// two gives its vertex the same normal as the quad. Face normals come from the corners
// in the order finalize() reads them, so that a flat patch gets its patch normal to the
// bit. Faces on the threads: each writes its own corners only.
void Scene::compute_missing_normals(int threads) {
    const int faces = static_cast<int>(mesh.n_faces());
    std::vector<Vec3> face_normal(mesh.n_faces());
    parallel_chunks(faces, threads, [&](int f0, int f1) {
        for (int i = f0; i < f1; ++i) {
            auto it = mesh.cfv_iter(TriMesh::FaceHandle(i));
            const Vec3 a = to_eigen(mesh.point(*it++));
            const Vec3 b = to_eigen(mesh.point(*it++));
            const Vec3 c = to_eigen(mesh.point(*it));
            face_normal[static_cast<std::size_t>(i)] = (b - a).cross(c - a).normalized();
        }
    });
    parallel_chunks(faces, threads, [&](int f0, int f1) {
        for (int i = f0; i < f1; ++i) {
            const TriMesh::FaceHandle f(i);
            const int object = mesh.property(object_handle, f);
            const double crease =
                object >= 0 && static_cast<std::size_t>(object) < crease_angles.size() ? crease_angles[object]
                                                                                        : default_crease_angle;
            const double min_cos = std::cos(crease * M_PI / 180.0);
            const Vec3& own = face_normal[static_cast<std::size_t>(i)];
            for (auto h : mesh.fh_range(f)) {
                auto& n = mesh.property(corner_normal_handle, h);
                if (n != std::array<double, 3>{0, 0, 0}) continue;
                if (!(crease > 0.0)) {
                    n = to_array(own);
                    continue;
                }
                // The patches around the vertex: each incoming halfedge ends there in its face.
                const auto v = mesh.to_vertex_handle(h);
                const Vec3 at = to_eigen(mesh.point(v));
                Vec3 sum = Vec3::Zero();
                for (auto in : mesh.vih_range(v)) {
                    const auto g = mesh.face_handle(in);
                    if (!g.is_valid() || face_normal[g.idx()].dot(own) < min_cos) continue;
                    const Vec3 e1 = to_eigen(mesh.point(mesh.from_vertex_handle(in))) - at;
                    const Vec3 e2 = to_eigen(mesh.point(mesh.to_vertex_handle(mesh.next_halfedge_handle(in)))) - at;
                    sum += std::atan2(e1.cross(e2).norm(), e1.dot(e2)) * face_normal[g.idx()];
                }
                n = to_array(sum.norm() > 0.0 ? Vec3(sum.normalized()) : own);
            }
        }
    });
}

Vec3 Scene::shading_normal(std::size_t patch, double b1, double b2) const {
    const auto& c = shading_normals[patch];
    const Vec3& front = patches[patch].normal;
    Vec3 n;
    if (c[0] == c[1] && c[1] == c[2]) {
        n = c[0];  // a flat patch: no rounding
    } else {
        n = (1.0 - b1 - b2) * c[0] + b1 * c[1] + b2 * c[2];
        const double length = n.norm();
        // Corner normals that cancel (only file normals can): the patch normal.
        if (!(length > 1e-9)) return front;
        n /= length;
    }
    return n.dot(front) < 0.0 ? Vec3(-n) : n;
}

void Scene::drop_degenerate(int object) {
    ++dropped_degenerate;
    if (object < 0) return;
    if (dropped_by_object.size() <= static_cast<std::size_t>(object)) dropped_by_object.resize(object + 1, 0);
    ++dropped_by_object[static_cast<std::size_t>(object)];
}

std::string Scene::dropped_summary() const {
    if (dropped_degenerate == 0) return "";
    std::string out = "dropped " + std::to_string(dropped_degenerate) + " zero-area triangle" +
                      (dropped_degenerate == 1 ? "" : "s");
    // The first four objects by name, the others counted.
    std::string per;
    std::size_t named = 0, more = 0;
    for (std::size_t i = 0; i < dropped_by_object.size() && i < object_names.size(); ++i) {
        if (dropped_by_object[i] == 0) continue;
        if (named == 4) {
            ++more;
            continue;
        }
        ++named;
        per += (per.empty() ? "" : ", ") + object_names[i] + " " + std::to_string(dropped_by_object[i]);
    }
    if (more > 0) per += " and " + std::to_string(more) + " more object" + (more == 1 ? "" : "s");
    return per.empty() ? out : out + " (" + per + ")";
}

void Scene::finalize(int threads) {
    // Drop zero-area triangles (they carry no light and break normals): found on the
    // threads, deleted in face order. Only this function deletes, and it collects the
    // garbage, so the faces are 0 .. n_faces() - 1 here and after.
    mesh.request_face_status();
    mesh.request_edge_status();
    mesh.request_vertex_status();
    std::vector<char> degenerate(mesh.n_faces(), 0);
    parallel_chunks(static_cast<int>(mesh.n_faces()), threads, [&](int f0, int f1) {
        for (int i = f0; i < f1; ++i) {
            auto it = mesh.cfv_iter(TriMesh::FaceHandle(i));
            const Vec3 a = to_eigen(mesh.point(*it++));
            const Vec3 b = to_eigen(mesh.point(*it++));
            const Vec3 c = to_eigen(mesh.point(*it));
            degenerate[static_cast<std::size_t>(i)] = zero_area(a, b, c);
        }
    });
    // A two-sided material's triangle and its twin (the same corners) are dropped
    // together and counted once, as the file's one triangle.
    std::size_t dropped = 0;
    std::map<int, std::size_t> twins;  // per object: two-sided triangles dropped
    for (std::size_t i = 0; i < degenerate.size(); ++i)
        if (degenerate[i]) {
            const TriMesh::FaceHandle f(static_cast<int>(i));
            const int object = mesh.property(object_handle, f);
            if (materials[static_cast<std::size_t>(mesh.property(material_handle, f))].two_sided)
                ++twins[object];
            else
                drop_degenerate(object);
            mesh.delete_face(f, true);
            ++dropped;
        }
    for (const auto& [object, n] : twins)
        for (std::size_t k = 0; k < (n + 1) / 2; ++k) drop_degenerate(object);
    // Vertices no face uses (those only triangles add_object() dropped had): gone too,
    // so that they count in no bounds.
    bool isolated = false;
    for (const auto v : mesh.vertices())
        if (mesh.is_isolated(v)) {
            mesh.delete_vertex(v, false);
            isolated = true;
        }
    if (dropped > 0 || isolated) mesh.garbage_collection();  // with nothing deleted it only copies
    compute_missing_normals(threads);

    // The flat vertices: one per mesh vertex, or, around a vertex on a contact edge, one
    // per set of patch corners that meet across edges that are not contact edges.
    std::vector<int> flat(mesh.n_halfedges(), -1);  // per halfedge: the flat vertex it ends at
    positions.clear();
    positions.reserve(mesh.n_vertices());
    const bool contacts = std::any_of(mesh.edges_begin(), mesh.edges_end(),
                                      [&](TriMesh::EdgeHandle e) { return mesh.property(contact_edge_handle, e); });
    if (!contacts) {
        positions.resize(mesh.n_vertices());
        parallel_chunks(static_cast<int>(mesh.n_vertices()), threads, [&](int v0, int v1) {
            for (int v = v0; v < v1; ++v)
                positions[static_cast<std::size_t>(v)] = to_eigen(mesh.point(TriMesh::VertexHandle(v)));
        });
        for (auto h : mesh.halfedges()) flat[h.idx()] = mesh.to_vertex_handle(h).idx();
    } else {
        // Around each vertex (on the threads: a halfedge ends at one vertex), its corners
        // (the halfedges into it inside faces) grouped across the edges that are not
        // contact edges, or all one group where the vertex is on no contact edge (also
        // where its patches meet only at it). Corner g and the one across the edge
        // leaving the vertex after it, opposite(next(g)), are joined. A group is keyed by
        // its first corner in face order: 3 f + the corner's place in fh_range(f).
        auto key = [&](TriMesh::HalfedgeHandle h) {
            const auto f = mesh.face_handle(h);
            const auto h0 = mesh.halfedge_handle(f);
            return 3 * f.idx() + (h == h0 ? 0 : h == mesh.next_halfedge_handle(h0) ? 1 : 2);
        };
        Buffer<int> first(mesh.n_halfedges());  // per corner: its group's key (scenes/buffer.h)
        parallel_chunks(static_cast<int>(mesh.n_vertices()), threads, [&](int v0, int v1) {
            std::vector<TriMesh::HalfedgeHandle> ring;
            std::vector<int> up, least;
            for (int v = v0; v < v1; ++v) {
                const TriMesh::VertexHandle vh(v);
                ring.clear();
                bool on_contact = false;
                for (auto h : mesh.vih_range(vh)) {
                    if (mesh.face_handle(h).is_valid()) ring.push_back(h);
                    on_contact = on_contact || mesh.property(contact_edge_handle, mesh.edge_handle(h));
                }
                const int d = static_cast<int>(ring.size());
                up.resize(ring.size());
                for (int i = 0; i < d; ++i) up[i] = on_contact ? i : 0;
                auto find = [&](int x) {
                    while (up[x] != x) x = up[x] = up[up[x]];
                    return x;
                };
                for (int i = 0; on_contact && i < d; ++i) {
                    const auto out = mesh.next_halfedge_handle(ring[i]);
                    const auto e = mesh.edge_handle(out);
                    if (mesh.property(contact_edge_handle, e) || mesh.is_boundary(e)) continue;
                    const auto across = mesh.opposite_halfedge_handle(out);  // into v, inside a face
                    int j = ring[(i + 1) % d] == across ? (i + 1) % d : ring[(i + d - 1) % d] == across ? (i + d - 1) % d : -1;
                    for (int k = 0; j < 0 && k < d; ++k)
                        if (ring[k] == across) j = k;
                    if (j < 0) throw std::logic_error("Scene::finalize: a vertex's ring lacks a corner across an edge");
                    up[find(i)] = find(j);
                }
                least.assign(ring.size(), std::numeric_limits<int>::max());
                for (int i = 0; i < d; ++i) least[find(i)] = std::min(least[find(i)], key(ring[i]));
                for (int i = 0; i < d; ++i) first[ring[i].idx()] = least[find(i)];
            }
        });
        // The flat vertices numbered in face order: blocks of faces count the corners
        // that begin a group, then number them from the counts before.
        const int faces = static_cast<int>(mesh.n_faces()), block = 4096, blocks = (faces + block - 1) / block;
        std::vector<int> begun(static_cast<std::size_t>(blocks) + 1, 0);
        auto corners = [&](int f, auto&& visit) {
            int k = 0;
            for (auto h : mesh.fh_range(TriMesh::FaceHandle(f))) visit(h, 3 * f + k++);
        };
        parallel_chunks(blocks, threads, [&](int b0, int b1) {
            for (int b = b0; b < b1; ++b)
                for (int f = b * block; f < std::min(faces, (b + 1) * block); ++f)
                    corners(f, [&](TriMesh::HalfedgeHandle h, int k) { begun[b + 1] += first[h.idx()] == k; });
        });
        for (int b = 0; b < blocks; ++b) begun[b + 1] += begun[b];
        positions.resize(static_cast<std::size_t>(begun[blocks]));
        parallel_chunks(blocks, threads, [&](int b0, int b1) {
            for (int b = b0; b < b1; ++b) {
                int next = begun[b];
                for (int f = b * block; f < std::min(faces, (b + 1) * block); ++f)
                    corners(f, [&](TriMesh::HalfedgeHandle h, int k) {
                        if (first[h.idx()] != k) return;
                        flat[h.idx()] = next;
                        positions[static_cast<std::size_t>(next++)] = to_eigen(mesh.point(mesh.to_vertex_handle(h)));
                    });
            }
        });
        // The other corners take their group's number from its first corner.
        parallel_chunks(faces, threads, [&](int f0, int f1) {
            for (int f = f0; f < f1; ++f)
                corners(f, [&](TriMesh::HalfedgeHandle h, int k) {
                    const int g = first[h.idx()];
                    if (g == k) return;
                    auto at = mesh.halfedge_handle(TriMesh::FaceHandle(g / 3));
                    for (int i = 0; i < g % 3; ++i) at = mesh.next_halfedge_handle(at);
                    flat[h.idx()] = flat[at.idx()];
                });
        });
    }

    // The patches on the threads, each from its own face; their area summed in order.
    patches.resize(mesh.n_faces());  // every field of every patch written below
    shading_normals.resize(mesh.n_faces());
    parallel_chunks(static_cast<int>(mesh.n_faces()), threads, [&](int f0, int f1) {
        for (int i = f0; i < f1; ++i) {
            const TriMesh::FaceHandle f(i);
            Patch& p = patches[static_cast<std::size_t>(i)];
            int k = 0;
            for (auto h : mesh.fh_range(f)) p.v[k++] = flat[h.idx()];  // the order of fv_range: each halfedge's head
            const Vec3& a = positions[p.v[0]];
            const Vec3& b = positions[p.v[1]];
            const Vec3& c = positions[p.v[2]];
            const Vec3 cross = (b - a).cross(c - a);
            p.area = 0.5 * cross.norm();
            p.normal = cross.normalized();
            p.centroid = (a + b + c) / 3.0;
            p.material = mesh.property(material_handle, f);
            p.object = mesh.property(object_handle, f);
            // The corner normals in the order of p.v; one within 1.4e-6 rad of the patch
            // normal (cos > 1 - 1e-12) is the patch normal.
            auto& corner = shading_normals[static_cast<std::size_t>(i)];
            for (auto h : mesh.fh_range(f)) {
                const int v = flat[h.idx()];
                const int slot = v == p.v[0] ? 0 : v == p.v[1] ? 1 : 2;
                const Vec3 n = to_eigen(mesh.property(corner_normal_handle, h));
                corner[slot] = n.dot(p.normal) > 1.0 - 1e-12 ? p.normal : n;
            }
        }
    });
    area_sum = 0.0;
    for (const Patch& p : patches) area_sum += p.area;
    if (patches.empty()) throw SceneError(name, "", "the scene has no patches");
    compute_albedos(threads);

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

// Per patch of a textured material with texture coordinates, the tint times the
// texture's mean over it: the texture at N^2 points, N four times the patch's longest
// edge in texels (4 to 64). Up to an edge of 16 texels the points are the centroids of
// the N^2 equal sub-triangles, a quarter of a texel apart at most: the midpoint rule on
// the bilinear lookup. A larger patch (or many repeats of a texture) gets 4,096 points
// of the R2 sequence (Roberts 2018) folded into the triangle, an estimate of its mean:
// a grid's rows, more than a quarter of a texel apart there, could fall in step with a
// periodic texture (a tiled checker) and read one of its colours. A deterministic sum, the same on any
// threads. Vertex colours multiply each point's texel; without a texture the patch's
// albedo is its material's times the colour at its centroid (the mean of an affine map).
void Scene::compute_albedos(int threads) {
    patch_texture_map.clear();
    patch_albedo.clear();
    if (texture_maps.empty()) return;
    const std::size_t n = patches.size();
    std::vector<int> maps(n, -1);
    bool any = false;
    for (std::size_t i = 0; i < n; ++i) {
        const int map = mesh.property(texture_map_handle, TriMesh::FaceHandle(static_cast<int>(i)));
        if (map < 0) continue;
        const TextureMap& maps_of = texture_maps[static_cast<std::size_t>(map)];
        if (maps_of.has_colour() || (maps_of.has_uv() && materials[static_cast<std::size_t>(patches[i].material)].texture))
            maps[i] = map, any = true;
    }
    if (!any) return;
    patch_texture_map = std::move(maps);
    patch_albedo.resize(n);
    parallel_chunks(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (int i = i0; i < i1; ++i) {
            const Patch& p = patches[static_cast<std::size_t>(i)];
            const Material& m = materials[static_cast<std::size_t>(p.material)];
            const int map = patch_texture_map[static_cast<std::size_t>(i)];
            if (map < 0) {
                patch_albedo[static_cast<std::size_t>(i)] = m.albedo;
                continue;
            }
            const TextureMap& to_uv = texture_maps[static_cast<std::size_t>(map)];
            const Vec3 &a = positions[p.v[0]], &b = positions[p.v[1]], &c = positions[p.v[2]];
            if (!(m.texture && to_uv.has_uv())) {  // vertex colours alone: an affine map's mean is its centroid's value
                patch_albedo[static_cast<std::size_t>(i)] = m.albedo * to_uv.colour((a + b + c) / 3.0);
                continue;
            }
            const Texture& texture = *m.texture;
            const Eigen::Array2d texels(texture.image->width, texture.image->height);
            const auto in_texels = [&](const Vec3& x, const Vec3& y) {
                return ((to_uv(x) - to_uv(y)).array() * texels).matrix().norm();
            };
            const double edge = std::max({in_texels(a, b), in_texels(b, c), in_texels(c, a)});
            const double wanted = std::isfinite(edge) ? std::ceil(4.0 * edge) : 65.0;
            const int N = static_cast<int>(std::clamp(wanted, 4.0, 64.0));
            Rgb sum = Rgb::Zero();
            const bool coloured = to_uv.has_colour();
            const auto add = [&](double u, double v) {
                const Vec3 x = a + u * (b - a) + v * (c - a);
                const Uv st = to_uv(x);
                sum += coloured ? texture.at(st.x(), st.y()) * to_uv.colour(x) : texture.at(st.x(), st.y());
            };
            if (wanted <= 64.0) {
                for (int s = 0; s < N; ++s)
                    for (int t = 0; s + t < N; ++t) {
                        add((s + 1.0 / 3.0) / N, (t + 1.0 / 3.0) / N);
                        if (s + t < N - 1) add((s + 2.0 / 3.0) / N, (t + 2.0 / 3.0) / N);
                    }
            } else {
                for (long k = 0; k < static_cast<long>(N) * N; ++k) {
                    double u = 0.5 + kR2[0] * static_cast<double>(k), v = 0.5 + kR2[1] * static_cast<double>(k);
                    u -= std::floor(u), v -= std::floor(v);
                    if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
                    add(u, v);
                }
            }
            patch_albedo[static_cast<std::size_t>(i)] = m.tint * sum / (static_cast<double>(N) * N);
        }
    });
}

Rgb Scene::albedo_at(std::size_t patch, const Vec3& x) const {
    if (patch_texture_map.empty()) return material_of(patch).albedo;
    const int map = patch_texture_map[patch];
    const Material& m = material_of(patch);
    if (map < 0) return m.albedo;
    const TextureMap& maps = texture_maps[static_cast<std::size_t>(map)];
    Rgb albedo = m.albedo;
    if (m.texture && maps.has_uv()) {
        const Uv st = maps(x);
        albedo = m.tint * m.texture->at(st.x(), st.y());
    }
    return maps.has_colour() ? albedo * maps.colour(x) : albedo;
}

namespace {

// m's values in `scratch` (not its name or texture), with another albedo.
const Material& with_albedo(const Material& m, const Rgb& albedo, Material& scratch) {
    scratch.albedo = albedo;
    scratch.emission = m.emission;
    scratch.specular = m.specular;
    scratch.exponent = m.exponent;
    scratch.two_sided = m.two_sided;
    return scratch;
}

}  // namespace

const Material& Scene::material_at(std::size_t patch, const Vec3& x, Material& scratch) const {
    const Material& m = material_of(patch);
    if (patch_texture_map.empty() || patch_texture_map[patch] < 0) return m;
    return with_albedo(m, albedo_at(patch, x), scratch);
}

const Material& Scene::patch_material(std::size_t patch, Material& scratch) const {
    const Material& m = material_of(patch);
    if (patch_texture_map.empty() || patch_texture_map[patch] < 0) return m;
    return with_albedo(m, patch_albedo[patch], scratch);
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

std::vector<std::pair<int, int>> plane_outline(const Scene& scene, const std::vector<std::uint32_t>& patches) {
    const auto& pos = scene.vertex_positions();
    std::map<std::pair<int, int>, int> count;  // directed edge -> how often, less the reverse's
    for (const std::uint32_t j : patches) {
        const auto& v = scene.patch_list()[j].v;
        for (int k = 0; k < 3; ++k) {
            const int from = v[k], to = v[(k + 1) % 3];
            if (auto back = count.find({to, from}); back != count.end() && back->second > 0) --back->second;
            else ++count[{from, to}];
        }
    }
    std::vector<std::pair<int, int>> edges;
    for (const auto& [edge, n] : count)
        for (int k = 0; k < n; ++k) edges.push_back(edge);
    // A vertex is passed through where exactly one edge enters and one leaves it, in one
    // direction (the sine of their angle within 1e-12: a midpoint's rounding).
    std::map<int, std::pair<int, int>> degree;  // vertex -> (edges in, edges out)
    std::map<int, std::size_t> leaving;         // vertex -> the edge that leaves it (one)
    for (std::size_t e = 0; e < edges.size(); ++e) {
        ++degree[edges[e].second].first;
        ++degree[edges[e].first].second;
        leaving[edges[e].first] = e;
    }
    std::map<int, int> entered_from;  // vertex -> the one edge's start, where one enters
    for (const auto& [from, to] : edges) entered_from[to] = from;
    auto straight = [&](int v) {
        const auto& [in, out] = degree[v];
        if (in != 1 || out != 1) return false;
        const Vec3 a = pos[entered_from[v]], b = pos[v], c = pos[edges[leaving[v]].second];
        const Vec3 d1 = b - a, d2 = c - b;
        return d1.dot(d2) > 0.0 && d1.cross(d2).norm() <= 1e-12 * d1.norm() * d2.norm();
    };
    std::vector<char> used(edges.size(), 0);
    std::vector<std::pair<int, int>> joined;
    for (std::size_t e = 0; e < edges.size(); ++e) {
        if (used[e] || straight(edges[e].first)) continue;  // joined edges start where one turns
        used[e] = 1;
        int to = edges[e].second;
        while (straight(to)) {
            const std::size_t next = leaving[to];
            if (used[next]) break;
            used[next] = 1;
            to = edges[next].second;
        }
        joined.emplace_back(edges[e].first, to);
    }
    for (std::size_t e = 0; e < edges.size(); ++e)  // a loop with no turn (degenerate): as it is
        if (!used[e]) joined.push_back(edges[e]);
    std::sort(joined.begin(), joined.end());
    return joined;
}

}  // namespace raybundle::scenes
