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

// Parses up to three coordinates with strtod (which, unlike streams, reads "nan" and
// "inf") and throws if one is missing or not finite.
void check_coordinates(const std::string& text, const std::string& shown, const std::string& where) {
    const char* p = text.c_str();
    for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        while (*p == ' ' || *p == '\t') ++p;
        const double x = std::strtod(p, &end);
        if (end == p) throw SceneError(shown, where, "vertex has fewer than 3 coordinates");
        if (!std::isfinite(x))
            throw SceneError(shown, where, "coordinate '" + std::string(p, static_cast<const char*>(end)) + "' is not finite");
        p = end;
    }
}

std::string lower_extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    if (dot == std::string::npos) return "";
    std::string ext = path.substr(dot + 1);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

// OBJ: every face corner must name an existing vertex (1-based, or negative = relative).
void check_obj(std::istream& in, const std::string& shown) {
    std::string line;
    long vertices = 0;
    long line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        if (tag == "v") {
            ++vertices;
            check_coordinates(line.substr(line.find('v') + 1), shown, "line " + std::to_string(line_no));
        } else if (tag == "f") {
            std::string corner;
            int corners = 0;
            while (ls >> corner) {
                ++corners;
                long idx = 0;
                try {
                    idx = std::stol(corner.substr(0, corner.find('/')));
                } catch (const std::exception&) {
                    throw SceneError(shown, "line " + std::to_string(line_no),
                                     "malformed face corner '" + corner + "'");
                }
                const long resolved = idx < 0 ? vertices + idx + 1 : idx;
                if (resolved < 1 || resolved > vertices)
                    throw SceneError(shown, "line " + std::to_string(line_no),
                                     "face references vertex " + std::to_string(idx) + ", but only " +
                                         std::to_string(vertices) + " vertices are defined before it");
            }
            if (corners < 3)
                throw SceneError(shown, "line " + std::to_string(line_no),
                                 "face has " + std::to_string(corners) + " corners (at least 3 needed)");
        }
    }
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
        check_coordinates(line, shown, "vertex " + std::to_string(i));
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

// PLY: the header's counts; for ASCII files also the number of data lines, which
// must cover them (a truncated file has fewer).
void read_ply_counts(std::istream& in, long& nv, long& nf, long& data_lines, bool& ascii) {
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("format ascii", 0) == 0) ascii = true;
        std::istringstream ls(line);
        std::string word, element;
        ls >> word;
        if (word == "element") {
            long n = 0;
            ls >> element >> n;
            if (element == "vertex") nv = n;
            if (element == "face") nf = n;
        }
        if (word == "end_header") break;
    }
    data_lines = 0;
    if (ascii)
        while (std::getline(in, line))
            if (line.find_first_not_of(" \t\r") != std::string::npos) ++data_lines;
}

}  // namespace

MeshData read_mesh_file(const std::string& path, const std::string& shown) {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw SceneError(shown, "", "cannot open mesh file");
    const std::string ext = lower_extension(path);
    long ply_nv = -1, ply_nf = -1, ply_lines = 0;
    bool ply_ascii = false;
    if (ext == "obj") {
        check_obj(probe, shown);
    } else if (ext == "off") {
        check_off(probe, shown);
    } else if (ext == "ply") {
        read_ply_counts(probe, ply_nv, ply_nf, ply_lines, ply_ascii);
        if (ply_ascii && ply_nv >= 0 && ply_nf >= 0 && ply_lines < ply_nv + ply_nf)
            throw SceneError(shown, "", "file is truncated: header promises " + std::to_string(ply_nv) +
                                            " vertices and " + std::to_string(ply_nf) + " faces, found " +
                                            std::to_string(ply_lines) + " data lines");
    } else {
        throw SceneError(shown, "", "unknown mesh format '." + ext + "' (known: .obj, .ply, .off)");
    }

    // OpenMesh prints its complaints itself; we report ours as one line instead.
    omerr().disable();
    omlog().disable();
    omout().disable();
    OpenMesh::PolyMesh_ArrayKernelT<OpenMesh::DefaultTraits> poly;
    OpenMesh::IO::Options options;
    const bool ok = OpenMesh::IO::read_mesh(poly, path, options);
    if (!ok) throw SceneError(shown, "", "OpenMesh could not read the mesh (malformed or truncated file)");
    // OpenMesh may add vertices (it duplicates them for non-manifold faces), never lose them.
    if (ply_nv >= 0 && static_cast<long>(poly.n_vertices()) < ply_nv)
        throw SceneError(shown, "", "file is truncated: header promises " + std::to_string(ply_nv) +
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
    for (auto f : poly.faces()) {
        std::vector<int> idx;
        for (auto v : poly.fv_range(f)) idx.push_back(v.idx());
        for (std::size_t k = 1; k + 1 < idx.size(); ++k) data.triangles.push_back({idx[0], idx[k], idx[k + 1]});
    }
    if (data.triangles.empty()) throw SceneError(shown, "", "the mesh has no faces");
    return data;
}

}  // namespace raybundle::scenes
