#include "scenes/mesh_readers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace raybundle::scenes::mesh_detail {

namespace {

// A line ending in a backslash (before any blanks and a carriage return).
bool ends_in_backslash(const std::string& line) {
    const auto last = line.find_last_not_of(" \t\r");
    return last != std::string::npos && line[last] == '\\';
}

// Cuts a comment off a statement of numbers: from a '#' at the start or after a blank.
void strip_comment(std::string& line) {
    for (std::size_t hash = line.find('#'); hash != std::string::npos; hash = line.find('#', hash + 1))
        if (hash == 0 || line[hash - 1] == ' ' || line[hash - 1] == '\t') {
            line.erase(hash);
            return;
        }
}

// Words a normal that is not finite is written as: "nan", "-nan(ind)", "inf",
// "infinity", and MSVC's "-1.#IND00", "1.#QNAN0", "1.#INF00" (whole words).
bool not_finite_words(const std::string& text) {
    std::istringstream words(text);
    for (std::string w; words >> w;) {
        for (char& c : w) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        if (!w.empty() && (w[0] == '-' || w[0] == '+')) w.erase(0, 1);
        if (w == "nan" || w.rfind("nan(", 0) == 0 || w == "inf" || w == "infinity") return true;
        if (w.rfind("1.#ind", 0) == 0 || w.rfind("1.#qnan", 0) == 0 || w.rfind("1.#inf", 0) == 0) return true;
    }
    return false;
}

}  // namespace

// ---------------------------------------------------------------------------- OBJ
// Read here rather than through OpenMesh, which keeps one normal per vertex: `v` and
// `vn` and `vt` lines and faces of corners `v`, `v/vt`, `v//vn`, `v/vt/vn` (1-based, or
// negative = relative), polygons split into a fan from their first corner; other
// lines are ignored. Every index must name an element defined
// before it. A UTF-8 byte order mark before the first line is skipped. `usemtl`, `o`,
// `g` and `mtllib` are recorded (MeshData): the material and group of each triangle.
MeshData read_obj(std::istream& in, const std::string& shown) {
    MeshData data;
    std::vector<Vec3> normals;
    bool any_normals = false;
    std::vector<std::array<Vec3, 3>> corner_normals;
    std::string line;
    long line_no = 0;
    std::vector<Uv> texture_coordinates;  // (s, t): t = 1 - v
    bool any_uvs = false;
    std::vector<std::array<Uv, 3>> corner_uvs;
    int material = -1, group = -1;
    bool tagged = false;  // a usemtl, o or g seen: every triangle gets its material and group
    // The rest of the line after its tag, without surrounding blanks (names may hold spaces).
    auto rest = [&line](const std::string& tag) {
        std::string r = line.substr(line.find(tag) + tag.size());
        const auto first = r.find_first_not_of(" \t\r"), last = r.find_last_not_of(" \t\r");
        return first == std::string::npos ? std::string() : r.substr(first, last - first + 1);
    };
    auto index_of = [](std::vector<std::string>& names, const std::string& name) {
        const auto it = std::find(names.begin(), names.end(), name);
        if (it != names.end()) return static_cast<int>(it - names.begin());
        names.push_back(name);
        return static_cast<int>(names.size() - 1);
    };
    long zero_normals = 0, first_zero = 0;  // `vn 0 0 0` or `vn nan nan nan`: its corners get computed normals
    long broken_normals = 0;                // of those, the ones not finite
    while (std::getline(in, line)) {
        // A UTF-8 byte order mark before the first line is not part of it.
        if (++line_no == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        const long first_line = line_no;
        std::string tag;
        std::istringstream(line) >> tag;
        // A statement of numbers: a comment may end it after a blank ("f 1 2 3 # the
        // floor"), and a backslash at its end joins the next line to it (errors name the
        // first; at the file's end it joins nothing). Names keep theirs: "usemtl Material
        // #25" is 3ds Max's name, as its MTL has it, and a backslash may end a folder.
        if (tag == "v" || tag == "vn" || tag == "vt" || tag == "vp" || tag == "f" || tag == "l" || tag == "p" ||
            tag == "s") {
            strip_comment(line);
            for (std::string next; ends_in_backslash(line); ++line_no) {
                line.erase(line.find_last_of('\\'));
                if (!std::getline(in, next)) break;
                strip_comment(next);
                line += " " + next;
            }
        }
        const std::string where = "line " + std::to_string(first_line);
        std::istringstream ls(line);
        ls >> tag;
        if (tag == "v") {
            data.vertices.push_back(read_coordinates(line.substr(line.find('v') + 1), shown, where));
        } else if (tag == "vn") {
            // Exporters write `vn 0 0 0`, or one not finite, at degenerate faces: no
            // direction, as if not given.
            const std::string text = line.substr(line.find("vn") + 2);
            const bool broken = not_finite_words(text);
            const Vec3 n = broken ? Vec3::Zero() : read_coordinates(text, shown, where, "normal");
            if (!(n.norm() > 0.0)) {
                if (zero_normals++ == 0) first_zero = first_line;
                broken_normals += broken;
            }
            normals.push_back(n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero());
        } else if (tag == "vt") {
            // "vt u [v [w]]": v 0 where not given, w ignored. One not finite ("nan", as
            // exporters write at degenerate faces, like a `vn`): no coordinates there.
            const std::string text = line.substr(line.find("vt") + 2);
            std::istringstream ts(text);
            std::vector<double> words;
            bool broken = false;  // u or v not finite (w is not read)
            for (std::string w; ts >> w;) {
                if (words.size() < 2 && not_finite_words(w)) {
                    broken = true;
                    words.push_back(std::numeric_limits<double>::quiet_NaN());
                    continue;
                }
                std::size_t used = 0;
                double x = 0.0;
                try {
                    x = std::stod(w, &used);
                } catch (const std::exception&) {
                    used = 0;
                }
                if (words.size() < 2 && (used == 0 || used != w.size() || !std::isfinite(x)))
                    throw SceneError(shown, where, "texture coordinate '" + w + "' is not a number");
                words.push_back(x);
            }
            if (words.empty() || words.size() > 3)
                throw SceneError(shown, where, "vt needs 1 to 3 numbers, got " + std::to_string(words.size()));
            constexpr double none = std::numeric_limits<double>::quiet_NaN();
            texture_coordinates.push_back(broken ? Uv(none, none)
                                                 : Uv(words[0], 1.0 - (words.size() > 1 ? words[1] : 0.0)));
        } else if (tag == "usemtl" || tag == "o" || tag == "g") {
            const std::string name = rest(tag);
            if (tag == "usemtl" && name.empty()) throw SceneError(shown, where, "usemtl without a material name");
            if (!tagged) {  // the triangles so far: no material, no group
                tagged = true;
                data.triangle_material.assign(data.triangles.size(), -1);
                data.triangle_group.assign(data.triangles.size(), -1);
            }
            if (tag == "usemtl") {
                material = index_of(data.materials, name);
                if (data.material_lines.size() < data.materials.size()) data.material_lines.push_back(first_line);
            }
            else
                group = index_of(data.groups, name.empty() ? "(unnamed)" : name);
        } else if (tag == "mtllib") {
            std::string name = rest(tag);
            if (name.empty()) throw SceneError(shown, where, "mtllib without a file name");
            std::replace(name.begin(), name.end(), '\\', '/');  // as Windows exporters write folders
            // Several files ("mtllib a.mtl b.mtl") where every word names an MTL file;
            // else one name, spaces and all ("mtllib my room.mtl").
            std::vector<std::string> words;
            std::istringstream ws(name);
            for (std::string w; ws >> w;) words.push_back(w);
            const auto mtl = [](const std::string& w) {
                return w.size() > 4 && (w.compare(w.size() - 4, 4, ".mtl") == 0 || w.compare(w.size() - 4, 4, ".MTL") == 0);
            };
            if (words.size() > 1 && std::all_of(words.begin(), words.end(), mtl))
                data.material_libraries.insert(data.material_libraries.end(), words.begin(), words.end());
            else
                data.material_libraries.push_back(name);
        } else if (tag == "f") {
            std::vector<int> vs;
            std::vector<Vec3> ns;
            std::vector<Uv> ts;
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
                    if (idx == 0)
                        throw SceneError(shown, where,
                                         std::string("face corner '") + corner + "': " + kind +
                                             " index 0 (OBJ counts from 1, and back from -1)");
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
                const long nt = static_cast<long>(texture_coordinates.size());
                if (slash != std::string::npos && slash + 1 < std::min(slash2, corner.size()))
                    ts.push_back(texture_coordinates[index(
                        corner.substr(slash + 1, std::min(slash2, corner.size()) - slash - 1), nt,
                        "texture coordinate", "texture coordinates")]);
                if (slash2 != std::string::npos && slash2 + 1 < corner.size())
                    ns.push_back(normals[index(corner.substr(slash2 + 1), nn, "normal", "normals")]);
            }
            check_triangle_fan(static_cast<long>(vs.size()), shown, where);
            if (!ns.empty() && ns.size() != vs.size())
                throw SceneError(shown, where,
                                 "face gives normals at " + std::to_string(ns.size()) + " of its " +
                                     std::to_string(vs.size()) + " corners");
            if (!ts.empty() && ts.size() != vs.size())
                throw SceneError(shown, where,
                                 "face gives texture coordinates at " + std::to_string(ts.size()) + " of its " +
                                     std::to_string(vs.size()) + " corners");
            any_normals = any_normals || !ns.empty();
            any_uvs = any_uvs || !ts.empty();
            // A polygon that is not one flat, simple face: named with its object (o or g),
            // and the way out, as a modeller's quads off their plane are common (a
            // subdivided surface exported as quads).
            const auto polygon = [&] {
                try {
                    return add_polygon(data, vs, shown, where);
                } catch (const SceneError& e) {
                    const std::string object = group >= 0 ? " (object " + data.groups[static_cast<std::size_t>(group)] + ")" : "";
                    const bool advised = e.problem().find("triangulate") != std::string::npos;
                    throw SceneError(shown, where + object,
                                     e.problem() + (advised ? "" : "; export the model triangulated (Blender: the OBJ "
                                                                   "exporter's Triangulated Mesh), or split the face "
                                                                   "into flat ones"));
                }
            }();
            for (const auto& t : polygon) {
                corner_normals.push_back(ns.empty() ? std::array<Vec3, 3>{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}
                                                    : std::array<Vec3, 3>{ns[t[0]], ns[t[1]], ns[t[2]]});
                constexpr double none = std::numeric_limits<double>::quiet_NaN();
                corner_uvs.push_back(ts.empty() ? std::array<Uv, 3>{Uv(none, none), Uv(none, none), Uv(none, none)}
                                                : std::array<Uv, 3>{ts[t[0]], ts[t[1]], ts[t[2]]});
                if (tagged) {
                    data.triangle_material.push_back(material);
                    data.triangle_group.push_back(group);
                }
            }
        }
    }
    if (any_normals) data.normals = std::move(corner_normals);
    if (any_uvs) data.uvs = std::move(corner_uvs);
    if (zero_normals > 0)
        data.warnings.push_back(zero_normals_warning(shown, zero_normals, "line " + std::to_string(first_zero),
                                                     broken_normals == 0              ? "of zero length"
                                                     : broken_normals == zero_normals ? "not finite"
                                                                                      : "of zero length or not finite"));
    return data;
}

}  // namespace raybundle::scenes::mesh_detail
