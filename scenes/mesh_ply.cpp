#include "scenes/mesh_readers.h"

#include <sstream>

namespace raybundle::scenes::mesh_detail {

// ---------------------------------------------------------------------------- PLY
// ASCII, binary little- and big-endian. The vertex element gives x, y, z and,
// optionally, all of nx, ny, nz and all of red, green, blue (or diffuse_red, ...); the
// face element a list named vertex_indices (or vertex_index); other elements and
// properties are read past. Every count is checked against the bytes left before
// anything is allocated for it.

namespace {

// A PLY colour value as linear: 8- and 16-bit integers over their maximum, floats as
// they are, each then read as sRGB (as scanners write them and Blender's importer reads them).
double ply_colour(double value, const PlyType& type) {
    const double c = std::clamp(type.real ? value : value / (type.bytes == 1 ? 255.0 : 65535.0), 0.0, 1.0);
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

}  // namespace

struct PlyProperty {
    std::string name;
    PlyType type;        // the value's type (a list's items)
    PlyType count_type;  // a list's count; bytes == 0 for a scalar
    bool list() const { return count_type.bytes != 0; }
};

struct PlyElement {
    std::string name;
    long count = 0;
    std::vector<PlyProperty> properties;
    // The fewest bytes one instance takes: its scalars, its lists' counts (binary); a
    // value and a separator per property (ASCII).
    long min_bytes(PlyFormat f) const {
        long n = 0;
        for (const auto& p : properties)
            n += f == PlyFormat::ascii ? 2 : (p.list() ? p.count_type.bytes : p.type.bytes);
        return n;
    }
};

MeshData read_ply(std::string_view content, const std::string& shown) {
    // The header: lines up to end_header.
    std::size_t pos = 0;
    long line_no = 0;
    auto header_line = [&](std::string& out) {
        if (pos >= content.size()) return false;
        auto end = content.find('\n', pos);
        if (end == std::string::npos) end = content.size();
        out = content.substr(pos, end - pos);
        if (!out.empty() && out.back() == '\r') out.pop_back();
        pos = end + 1;
        ++line_no;
        return true;
    };
    std::string line;
    if (!header_line(line) || line != "ply") throw SceneError(shown, "header", "not a PLY file (no 'ply' line first)");
    PlyFormat format = PlyFormat::ascii;
    bool have_format = false, ended = false;
    std::vector<PlyElement> elements;
    while (header_line(line)) {
        const std::string where = "header line " + std::to_string(line_no);
        std::istringstream ls(line);
        std::string word;
        ls >> word;
        if (word == "end_header") {
            ended = true;
            break;
        }
        if (word.empty() || word == "comment" || word == "obj_info") continue;
        if (word == "format") {
            std::string name, version;
            ls >> name >> version;
            if (name == "ascii") format = PlyFormat::ascii;
            else if (name == "binary_little_endian") format = PlyFormat::binary_le;
            else if (name == "binary_big_endian") format = PlyFormat::binary_be;
            else
                throw SceneError(shown, where, "unknown format '" + name +
                                                   "' (known: ascii, binary_little_endian, binary_big_endian)");
            if (version != "1.0") throw SceneError(shown, where, "unknown version '" + version + "' (known: 1.0)");
            have_format = true;
        } else if (word == "element") {
            std::string name, count;
            if (!(ls >> name >> count)) throw SceneError(shown, where, "element needs a name and a count");
            elements.push_back({name, parse_count(count, shown, where, "element count"), {}});
        } else if (word == "property") {
            if (elements.empty()) throw SceneError(shown, where, "property before any element");
            std::string type, name;
            ls >> type;
            PlyProperty p;
            if (type == "list") {
                std::string count_type;
                ls >> count_type >> type;
                p.count_type = ply_type(count_type);
                if (p.count_type.bytes == 0 || p.count_type.real)
                    throw SceneError(shown, where, "list count type '" + count_type + "' is not an integer type");
            }
            p.type = ply_type(type);
            if (p.type.bytes == 0) throw SceneError(shown, where, "unknown property type '" + type + "'");
            if (!(ls >> name)) throw SceneError(shown, where, "property has no name");
            p.name = name;
            elements.back().properties.push_back(p);
        } else {
            throw SceneError(shown, where, "unknown header keyword '" + word + "'");
        }
    }
    if (!ended) throw SceneError(shown, "header", "no end_header line");
    if (!have_format) throw SceneError(shown, "header", "no format line");

    // What we need of the vertex and face elements.
    const PlyElement* vertex = nullptr;
    const PlyElement* face = nullptr;
    for (const auto& e : elements) {
        if (e.name == "vertex" && !vertex) vertex = &e;
        if (e.name == "face" && !face) face = &e;
    }
    if (!vertex) throw SceneError(shown, "header", "no vertex element");
    auto find = [](const PlyElement& e, const std::string& name) {
        for (std::size_t i = 0; i < e.properties.size(); ++i)
            if (e.properties[i].name == name) return static_cast<int>(i);
        return -1;
    };
    int xyz[3], nxyz[3];
    std::string found_normals;
    for (int k = 0; k < 3; ++k) {
        const std::string axis(1, "xyz"[k]);
        xyz[k] = find(*vertex, axis);
        if (xyz[k] < 0 || vertex->properties[xyz[k]].list())
            throw SceneError(shown, "header", "the vertex element has no property " + axis);
        nxyz[k] = find(*vertex, "n" + axis);
        if (nxyz[k] >= 0) found_normals += (found_normals.empty() ? "n" : ", n") + axis;
    }
    const bool has_normals = nxyz[0] >= 0 && nxyz[1] >= 0 && nxyz[2] >= 0;
    if (!found_normals.empty() && !has_normals)
        throw SceneError(shown, "header", "vertex normals need all of nx, ny, nz (found " + found_normals + ")");
    // Vertex colours: red, green, blue (or MeshLab's diffuse_red, ...), scalars of at
    // most 16 bits or floats.
    int rgb[3];
    std::string found_colours;
    for (const std::string prefix : {"", "diffuse_"}) {
        found_colours.clear();
        for (int k = 0; k < 3; ++k) {
            const std::string name = prefix + std::array{"red", "green", "blue"}[k];
            rgb[k] = find(*vertex, name);
            if (rgb[k] >= 0) found_colours += (found_colours.empty() ? "" : ", ") + name;
        }
        if (!found_colours.empty()) break;
    }
    const bool has_colours = rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0;
    std::vector<std::string> header_warnings;
    if (!found_colours.empty() && !has_colours)
        header_warnings.push_back(shown + ": header: vertex colours need all of red, green, blue (found " +
                                  found_colours + "): not read");
    if (has_colours)
        for (const int k : rgb) {
            const PlyProperty& p = vertex->properties[static_cast<std::size_t>(k)];
            if (p.list() || (!p.type.real && (p.type.bytes > 2 || p.type.is_signed)))
                throw SceneError(shown, "header", "vertex colour " + p.name + " is " +
                                                      (p.list()           ? "a list"
                                                       : p.type.is_signed ? "a signed integer"
                                                                          : "an integer of more than 16 bits") +
                                                      " (a PLY colour is uchar, ushort, float or double)");
        }
    int indices = -1;
    if (face) {
        indices = find(*face, "vertex_indices");
        if (indices < 0) indices = find(*face, "vertex_index");
        if (indices < 0 || !face->properties[indices].list() || face->properties[indices].type.real)
            throw SceneError(shown, "header", "the face element has no integer list vertex_indices");
    }
    if (!face || face->count == 0) throw SceneError(shown, "", "the mesh has no faces");

    // The body.
    PlyValues values(std::string_view(content).substr(std::min(pos, content.size())), format, shown);
    MeshData data;
    std::vector<Vec3> normals;
    std::vector<Rgb> colours;
    long clamped_colours = 0;
    std::string first_clamped;
    long zero_normals = 0;
    std::string first_zero;
    std::vector<std::vector<int>> faces;
    std::vector<double> row;
    std::string holds;  // what the header says an element holds, for a line that does not (values' rows point here)
    for (const auto& e : elements) {
        check_room(e.count, e.min_bytes(format), values.remaining(), shown, e.name,
                   e.name == "vertex" ? "vertices" : e.name == "face" ? "faces" : e.name + " elements");
        const bool is_vertex = &e == vertex, is_face = &e == face;
        if (is_vertex) {
            data.vertices.reserve(static_cast<std::size_t>(e.count));
            if (has_normals) normals.reserve(static_cast<std::size_t>(e.count));
            if (has_colours) colours.reserve(static_cast<std::size_t>(e.count));
        }
        if (is_face) faces.reserve(static_cast<std::size_t>(e.count));
        if (e.properties.empty()) continue;
        holds.clear();
        for (const auto& prop : e.properties) holds += (holds.empty() ? "" : ", ") + prop.name + (prop.list() ? " (a list)" : "");
        holds = "the header gives each " + e.name + " " + holds + ", and counts " + std::to_string(e.count);
        for (long i = 0; i < e.count; ++i) {
            const auto where = [&e, i] { return e.name + " " + std::to_string(i); };
            values.begin_row(holds);
            row.assign(e.properties.size(), 0.0);
            for (std::size_t p = 0; p < e.properties.size(); ++p) {
                const PlyProperty& prop = e.properties[p];
                if (!prop.list()) {
                    row[p] = values.next(prop.type, where);
                    continue;
                }
                const double n = values.next(prop.count_type, where);
                if (n < 0) throw SceneError(shown, where(), "negative list length " + std::to_string(static_cast<long long>(n)));
                const long count = static_cast<long>(n);
                check_room(count, format == PlyFormat::ascii ? 2 : prop.type.bytes, values.remaining(), shown, where(),
                           "list items");
                if (is_face && static_cast<int>(p) == indices) {
                    if (count < 3 && p + 1 == e.properties.size()) {  // "0 1 0": a vertex read as a face (the header's counts), or a short face
                        for (long c = 0; c < count; ++c) values.next(prop.type, where);
                        values.end_row(where);
                    }
                    check_triangle_fan(count, shown, where());
                    std::vector<int> corners;
                    corners.reserve(static_cast<std::size_t>(count));
                    for (long c = 0; c < count; ++c) {
                        const double idx = values.next(prop.type, where);
                        if (idx < 0 || idx >= static_cast<double>(vertex->count))
                            throw SceneError(shown, where(),
                                             "references vertex " + std::to_string(static_cast<long long>(idx)) +
                                                 ", but the file has " + std::to_string(vertex->count) + " vertices");
                        corners.push_back(static_cast<int>(idx));
                    }
                    faces.push_back(std::move(corners));
                } else {
                    for (long c = 0; c < count; ++c) values.next(prop.type, where);
                }
            }
            values.end_row(where);
            if (is_vertex) {
                const Vec3 p(row[xyz[0]], row[xyz[1]], row[xyz[2]]);
                if (!p.allFinite()) throw SceneError(shown, where(), "coordinate " + vector_text(p) + " is not finite");
                data.vertices.push_back(p);
                if (has_normals) {
                    const Vec3 n(row[nxyz[0]], row[nxyz[1]], row[nxyz[2]]);
                    if (!n.allFinite()) throw SceneError(shown, where(), "normal " + vector_text(n) + " is not finite");
                    // A zero normal (at a degenerate face) has no direction: as if not given.
                    if (!(n.norm() > 0.0) && zero_normals++ == 0) first_zero = where();
                    normals.push_back(n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero());
                }
                if (has_colours) {
                    Rgb c;
                    for (int k = 0; k < 3; ++k) {
                        const double v = row[static_cast<std::size_t>(rgb[k])];
                        if (!std::isfinite(v)) throw SceneError(shown, where(), "colour value " + std::to_string(v) + " is not finite");
                        const PlyType& type = vertex->properties[static_cast<std::size_t>(rgb[k])].type;
                        if (type.real && !(v >= 0.0 && v <= 1.0) && clamped_colours++ == 0) first_clamped = where();
                        c[k] = ply_colour(v, type);
                    }
                    colours.push_back(c);
                }
            }
        }
    }
    for (std::size_t f = 0; f < faces.size(); ++f) {
        const auto& corners = faces[f];
        const auto local = add_polygon(data, corners, shown, "face " + std::to_string(f));
        if (has_normals)
            for (const auto& t : local)
                data.normals.push_back({normals[corners[t[0]]], normals[corners[t[1]]], normals[corners[t[2]]]});
        if (has_colours)
            for (const auto& t : local)
                data.colours.push_back({colours[corners[t[0]]], colours[corners[t[1]]], colours[corners[t[2]]]});
    }
    if (zero_normals > 0) data.warnings.push_back(zero_normals_warning(shown, zero_normals, first_zero, "of zero length"));
    data.warnings.insert(data.warnings.end(), header_warnings.begin(), header_warnings.end());
    if (clamped_colours > 0)
        data.warnings.push_back(shown + ": " + std::to_string(clamped_colours) + " float colour value" +
                                (clamped_colours == 1 ? "" : "s") + " outside 0..1 (the first at " + first_clamped +
                                ") clamped");
    return data;
}

}  // namespace raybundle::scenes::mesh_detail
