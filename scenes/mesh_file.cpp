#include "scenes/mesh_file.h"

#include "scenes/errors.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace raybundle::scenes {
namespace {

// Parses three coordinates with strtod (which, unlike streams, reads "nan" and "inf")
// and throws if one is missing or not finite; `what` names them in the message
// ("vertex", "normal").
Vec3 read_coordinates(const std::string& text, const std::string& shown, const std::string& where,
                      const std::string& what = "vertex") {
    const char* p = text.c_str();
    Vec3 r;
    for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        while (*p == ' ' || *p == '\t') ++p;
        const double x = std::strtod(p, &end);
        if (end == p) throw SceneError(shown, where, what + " has fewer than 3 coordinates");
        if (!std::isfinite(x))
            throw SceneError(shown, where,
                             (what == "vertex" ? "" : what + " ") + "coordinate '" +
                                 std::string(p, static_cast<const char*>(end)) + "' is not finite");
        r[k] = x;
        p = end;
    }
    return r;
}

std::string vector_text(const Vec3& v) {
    std::ostringstream os;
    os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    return os.str();
}

std::string lower_extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    if (dot == std::string::npos) return "";
    std::string ext = path.substr(dot + 1);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

// OBJ, read here rather than through OpenMesh, which keeps one normal per vertex:
// `v` and `vn` lines and faces of corners `v`, `v/vt`, `v//vn`, `v/vt/vn` (1-based, or
// negative = relative), polygons split into a fan from their first corner; other
// lines are ignored. Every index must name an element defined before it.
MeshData read_obj(std::istream& in, const std::string& shown) {
    MeshData data;
    std::vector<Vec3> normals;
    bool any_normals = false;
    std::vector<std::array<Vec3, 3>> corner_normals;
    std::string line;
    long line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string where = "line " + std::to_string(line_no);
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        if (tag == "v") {
            data.vertices.push_back(read_coordinates(line.substr(line.find('v') + 1), shown, where));
        } else if (tag == "vn") {
            const Vec3 n = read_coordinates(line.substr(line.find("vn") + 2), shown, where, "normal");
            if (!(n.norm() > 0.0)) throw SceneError(shown, where, "normal " + vector_text(n) + " has zero length");
            normals.push_back(n.normalized());
        } else if (tag == "f") {
            std::vector<int> vs;
            std::vector<Vec3> ns;
            std::string corner;
            while (ls >> corner) {
                // "v", "v/vt", "v//vn" or "v/vt/vn": the first and the third field.
                const auto slash = corner.find('/');
                const auto slash2 = slash == std::string::npos ? std::string::npos : corner.find('/', slash + 1);
                auto index = [&](const std::string& text, long count, const char* kind, const char* kinds) {
                    long idx = 0;
                    std::size_t used = 0;
                    try {
                        idx = std::stol(text, &used);
                    } catch (const std::exception&) {
                        used = 0;
                    }
                    if (used == 0 || used != text.size())
                        throw SceneError(shown, where, "malformed face corner '" + corner + "'");
                    const long resolved = idx < 0 ? count + idx + 1 : idx;
                    if (resolved < 1 || resolved > count)
                        throw SceneError(shown, where,
                                         std::string("face references ") + kind + " " + std::to_string(idx) +
                                             ", but only " + std::to_string(count) + " " +
                                             (count == 1 ? kind + std::string(" is") : kinds + std::string(" are")) +
                                             " defined before it");
                    return static_cast<int>(resolved - 1);
                };
                const long nv = static_cast<long>(data.vertices.size()), nn = static_cast<long>(normals.size());
                vs.push_back(index(corner.substr(0, slash), nv, "vertex", "vertices"));
                if (slash2 != std::string::npos && slash2 + 1 < corner.size())
                    ns.push_back(normals[index(corner.substr(slash2 + 1), nn, "normal", "normals")]);
            }
            if (vs.size() < 3)
                throw SceneError(shown, where,
                                 "face has " + std::to_string(vs.size()) + " corners (at least 3 needed)");
            if (!ns.empty() && ns.size() != vs.size())
                throw SceneError(shown, where,
                                 "face gives normals at " + std::to_string(ns.size()) + " of its " +
                                     std::to_string(vs.size()) + " corners");
            any_normals = any_normals || !ns.empty();
            for (std::size_t k = 1; k + 1 < vs.size(); ++k) {
                data.triangles.push_back({vs[0], vs[k], vs[k + 1]});
                corner_normals.push_back(ns.empty() ? std::array<Vec3, 3>{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}
                                                    : std::array<Vec3, 3>{ns[0], ns[k], ns[k + 1]});
            }
        }
    }
    if (any_normals) data.normals = std::move(corner_normals);
    return data;
}

// OFF: the header's counts must be met and every face index be in range.
void check_off(std::istream& in, const std::string& shown) {
    auto next_line = [&](std::string& out) {
        while (std::getline(in, out)) {
            const auto hash = out.find('#');
            if (hash != std::string::npos) out.erase(hash);
            if (out.find_first_not_of(" \t\r") != std::string::npos) return true;
        }
        return false;
    };
    std::string line;
    if (!next_line(line)) throw SceneError(shown, "header", "empty file");
    std::istringstream hs(line);
    std::string magic;
    hs >> magic;
    if (magic.find("OFF") == std::string::npos) throw SceneError(shown, "header", "not an OFF file ('" + magic + "')");
    long nv = -1, nf = -1;
    if (!(hs >> nv)) {
        if (!next_line(line)) throw SceneError(shown, "header", "missing vertex and face counts");
        hs = std::istringstream(line);
        hs >> nv;
    }
    if (!(hs >> nf) || nv < 0 || nf < 0) throw SceneError(shown, "header", "malformed vertex and face counts");
    if (magic.find("BINARY") != std::string::npos) return;  // binary OFF: OpenMesh's own checks
    for (long i = 0; i < nv; ++i) {
        if (!next_line(line))
            throw SceneError(shown, "vertices",
                             "file is truncated: header promises " + std::to_string(nv) + " vertices, found " +
                                 std::to_string(i));
        read_coordinates(line, shown, "vertex " + std::to_string(i));
    }
    for (long i = 0; i < nf; ++i) {
        if (!next_line(line))
            throw SceneError(shown, "faces",
                             "file is truncated: header promises " + std::to_string(nf) + " faces, found " +
                                 std::to_string(i));
        std::istringstream fs(line);
        long k = 0;
        fs >> k;
        for (long c = 0; c < k; ++c) {
            long idx = -1;
            if (!(fs >> idx))
                throw SceneError(shown, "face " + std::to_string(i),
                                 "has fewer than the " + std::to_string(k) + " indices it announces");
            if (idx < 0 || idx >= nv)
                throw SceneError(shown, "face " + std::to_string(i),
                                 "references vertex " + std::to_string(idx) + ", but the file has " +
                                     std::to_string(nv) + " vertices");
        }
    }
}

// PLY: the header's counts and which of the vertex properties nx, ny, nz it has; for
// ASCII files also the number of data lines, which must cover the counts (a truncated
// file has fewer).
struct PlyHeader {
    long nv = -1, nf = -1, data_lines = 0;
    bool ascii = false;
    std::vector<std::string> normal_properties;  // those of nx, ny, nz on the vertex element
};

PlyHeader read_ply_header(std::istream& in) {
    PlyHeader h;
    std::string line, current;
    while (std::getline(in, line)) {
        if (line.rfind("format ascii", 0) == 0) h.ascii = true;
        std::istringstream ls(line);
        std::string word, element;
        ls >> word;
        if (word == "element") {
            long n = 0;
            ls >> element >> n;
            current = element;
            if (element == "vertex") h.nv = n;
            if (element == "face") h.nf = n;
        }
        if (word == "property" && current == "vertex") {
            std::string type, name;
            ls >> type >> name;
            if (name == "nx" || name == "ny" || name == "nz") h.normal_properties.push_back(name);
        }
        if (word == "end_header") break;
    }
    if (h.ascii)
        while (std::getline(in, line))
            if (line.find_first_not_of(" \t\r") != std::string::npos) ++h.data_lines;
    return h;
}

}  // namespace

MeshData read_mesh_file(const std::string& path, const std::string& shown) {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw SceneError(shown, "", "cannot open mesh file");
    const std::string ext = lower_extension(path);
    PlyHeader ply;
    if (ext == "obj") {
        MeshData data = read_obj(probe, shown);
        if (data.triangles.empty()) throw SceneError(shown, "", "the mesh has no faces");
        return data;
    } else if (ext == "off") {
        check_off(probe, shown);
    } else if (ext == "ply") {
        ply = read_ply_header(probe);
        if (ply.ascii && ply.nv >= 0 && ply.nf >= 0 && ply.data_lines < ply.nv + ply.nf)
            throw SceneError(shown, "", "file is truncated: header promises " + std::to_string(ply.nv) +
                                            " vertices and " + std::to_string(ply.nf) + " faces, found " +
                                            std::to_string(ply.data_lines) + " data lines");
        if (!ply.normal_properties.empty() && ply.normal_properties.size() != 3) {
            std::string found;
            for (const auto& name : ply.normal_properties) found += (found.empty() ? "" : ", ") + name;
            throw SceneError(shown, "header", "vertex normals need all of nx, ny, nz (found " + found + ")");
        }
    } else {
        throw SceneError(shown, "", "unknown mesh format '." + ext + "' (known: .obj, .ply, .off)");
    }
    const bool ply_normals = ply.normal_properties.size() == 3;

    // OpenMesh prints its complaints itself; we report ours as one line instead.
    omerr().disable();
    omlog().disable();
    omout().disable();
    OpenMesh::PolyMesh_ArrayKernelT<OpenMesh::DefaultTraits> poly;
    OpenMesh::IO::Options options;
    if (ply_normals) {
        poly.request_vertex_normals();
        options += OpenMesh::IO::Options::VertexNormal;
    }
    const bool ok = OpenMesh::IO::read_mesh(poly, path, options);
    if (!ok) throw SceneError(shown, "", "OpenMesh could not read the mesh (malformed or truncated file)");
    // OpenMesh may add vertices (it duplicates them for non-manifold faces), never lose them.
    if (ply.nv >= 0 && static_cast<long>(poly.n_vertices()) < ply.nv)
        throw SceneError(shown, "", "file is truncated: header promises " + std::to_string(ply.nv) +
                                        " vertices, read " + std::to_string(poly.n_vertices()));

    MeshData data;
    data.vertices.reserve(poly.n_vertices());
    for (auto v : poly.vertices()) {
        const auto p = poly.point(v);
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
            std::ostringstream os;
            os << "coordinate (" << p[0] << ", " << p[1] << ", " << p[2] << ") is not finite";
            throw SceneError(shown, "vertex " + std::to_string(v.idx()), os.str());
        }
        data.vertices.emplace_back(p[0], p[1], p[2]);
    }
    // The file's vertex normals; the copies OpenMesh makes of vertices for non-manifold
    // faces (indices from nv on) have none, so finalize() computes theirs.
    std::vector<Vec3> normals;
    if (ply_normals) {
        normals.assign(poly.n_vertices(), Vec3::Zero());
        for (auto v : poly.vertices()) {
            if (v.idx() >= ply.nv) continue;
            const auto n = poly.normal(v);
            const Vec3 e(n[0], n[1], n[2]);
            const std::string where = "vertex " + std::to_string(v.idx());
            if (!e.allFinite()) throw SceneError(shown, where, "normal " + vector_text(e) + " is not finite");
            if (!(e.norm() > 0.0)) throw SceneError(shown, where, "normal " + vector_text(e) + " has zero length");
            normals[v.idx()] = e.normalized();
        }
    }
    for (auto f : poly.faces()) {
        std::vector<int> idx;
        for (auto v : poly.fv_range(f)) idx.push_back(v.idx());
        for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
            data.triangles.push_back({idx[0], idx[k], idx[k + 1]});
            if (ply_normals) data.normals.push_back({normals[idx[0]], normals[idx[k]], normals[idx[k + 1]]});
        }
    }
    if (data.triangles.empty()) throw SceneError(shown, "", "the mesh has no faces");
    return data;
}

}  // namespace raybundle::scenes
