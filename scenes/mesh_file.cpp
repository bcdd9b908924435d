#include "scenes/mesh_file.h"

#include "scenes/errors.h"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>

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

// A count from a header: a whole number in [0, 2^31). "-3", "inf", "1e9" and
// "2147483648" are refused here rather than trusted until an allocation fails.
long parse_count(const std::string& text, const std::string& shown, const std::string& where,
                 const std::string& what) {
    bool digits = !text.empty() && text.size() <= 10 &&
                  std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
    const long long n = digits ? std::strtoll(text.c_str(), nullptr, 10) : -1;
    if (!digits || n > std::numeric_limits<int>::max())
        throw SceneError(shown, where, what + " '" + text + "' is not a count (a whole number below 2^31)");
    return static_cast<long>(n);
}

// Refuses `count` elements of at least `each` bytes in `bytes` bytes (with one byte of
// slack: the last line of a text file may lack its newline). Only a bound, so that no
// count is trusted beyond what the file can hold before allocating for it; the
// readers find the exact end.
void check_room(long count, long each, std::size_t bytes, const std::string& shown, const std::string& where,
                const std::string& what) {
    if (each > 0 && static_cast<unsigned long long>(count) * static_cast<unsigned long long>(each) > bytes + 1)
        throw SceneError(shown, where,
                         "file is truncated: header promises " + std::to_string(count) + " " + what + ", the " +
                             std::to_string(bytes) + " bytes after it hold at most " +
                             std::to_string(bytes / static_cast<std::size_t>(each)));
}

void check_triangle_fan(long corners, const std::string& shown, const std::string& where) {
    if (corners < 3)
        throw SceneError(shown, where, "face has " + std::to_string(corners) + " corners (at least 3 needed)");
}

// Adds the face's triangles (vertex indices) and returns them as positions in
// `corners` (for the corner normals).
std::vector<std::array<int, 3>> add_polygon(MeshData& data, const std::vector<int>& corners, const std::string& shown,
                                            const std::string& where) {
    std::vector<std::array<int, 3>> local;
    if (corners.size() == 3) {
        local = {{0, 1, 2}};
    } else {
        std::vector<Vec3> points;
        points.reserve(corners.size());
        for (int c : corners) points.push_back(data.vertices[static_cast<std::size_t>(c)]);
        local = triangulate_polygon(points, kMeshPolygonBend, shown, where);
    }
    for (const auto& t : local) data.triangles.push_back({corners[t[0]], corners[t[1]], corners[t[2]]});
    return local;
}

// ---------------------------------------------------------------------------- OBJ
// Read here rather than through OpenMesh, which keeps one normal per vertex: `v` and
// `vn` lines and faces of corners `v`, `v/vt`, `v//vn`, `v/vt/vn` (1-based, or
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
            check_triangle_fan(static_cast<long>(vs.size()), shown, where);
            if (!ns.empty() && ns.size() != vs.size())
                throw SceneError(shown, where,
                                 "face gives normals at " + std::to_string(ns.size()) + " of its " +
                                     std::to_string(vs.size()) + " corners");
            any_normals = any_normals || !ns.empty();
            for (const auto& t : add_polygon(data, vs, shown, where))
                corner_normals.push_back(ns.empty() ? std::array<Vec3, 3>{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}
                                                    : std::array<Vec3, 3>{ns[t[0]], ns[t[1]], ns[t[2]]});
        }
    }
    if (any_normals) data.normals = std::move(corner_normals);
    return data;
}

// ------------------------------------------------------------- binary and text values
// The values of a PLY body (and of binary OFF, big-endian), one at a time.

enum class PlyFormat { ascii, binary_le, binary_be };

struct PlyType {
    int bytes = 0;  // 0: unknown
    bool real = false, is_signed = false;
};

PlyType ply_type(const std::string& name) {
    if (name == "char" || name == "int8") return {1, false, true};
    if (name == "uchar" || name == "uint8") return {1, false, false};
    if (name == "short" || name == "int16") return {2, false, true};
    if (name == "ushort" || name == "uint16") return {2, false, false};
    if (name == "int" || name == "int32") return {4, false, true};
    if (name == "uint" || name == "uint32") return {4, false, false};
    if (name == "float" || name == "float32") return {4, true, true};
    if (name == "double" || name == "float64") return {8, true, true};
    return {};
}

// The values of a PLY body, one at a time, as doubles (every PLY type fits exactly
// but 64-bit integers, which PLY does not have).
class PlyValues {
public:
    PlyValues(std::string_view body, PlyFormat format, const std::string& shown)
        : body_(body), format_(format), shown_(shown) {}

    // `where()` names the element in an error (built only then).
    template <class Where>
    double next(const PlyType& type, const Where& where) {
        if (format_ == PlyFormat::ascii) {
            while (pos_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[pos_]))) ++pos_;
            if (pos_ == body_.size()) throw truncated(where());
            std::size_t end = pos_;
            while (end < body_.size() && !std::isspace(static_cast<unsigned char>(body_[end]))) ++end;
            // strtod on a copy: the body need not end in a NUL (parse_mesh takes a view).
            const std::string token(body_.substr(pos_, end - pos_));
            char* stop = nullptr;
            const double v = std::strtod(token.c_str(), &stop);
            const bool whole = stop == token.c_str() + token.size();
            pos_ = end;
            if (!whole) throw SceneError(shown_, where(), "malformed value '" + token + "'");
            if (!std::isfinite(v)) throw SceneError(shown_, where(), "value '" + token + "' is not finite");
            if (!type.real && v != std::floor(v))
                throw SceneError(shown_, where(), "value '" + token + "' is not a whole number");
            if (!type.real) {
                // Within its declared type, as a binary file's value is by construction.
                const int bits = 8 * type.bytes;
                const double low = type.is_signed ? -std::ldexp(1.0, bits - 1) : 0.0;
                const double high = type.is_signed ? std::ldexp(1.0, bits - 1) - 1.0 : std::ldexp(1.0, bits) - 1.0;
                if (v < low || v > high)
                    throw SceneError(shown_, where(),
                                     "value '" + token + "' is outside its type's range (" +
                                         std::to_string(static_cast<long long>(low)) + " to " +
                                         std::to_string(static_cast<long long>(high)) + ")");
            }
            return v;
        }
        if (body_.size() - pos_ < static_cast<std::size_t>(type.bytes)) throw truncated(where());
        unsigned char b[8];
        std::memcpy(b, body_.data() + pos_, static_cast<std::size_t>(type.bytes));
        pos_ += static_cast<std::size_t>(type.bytes);
        if ((format_ == PlyFormat::binary_be) == host_little_endian()) std::reverse(b, b + type.bytes);
        switch (type.bytes) {
            case 1: return type.is_signed ? static_cast<double>(static_cast<std::int8_t>(b[0])) : b[0];
            case 2: return scalar<std::int16_t, std::uint16_t>(b, type);
            case 4:
                if (type.real) {
                    float f;
                    std::memcpy(&f, b, 4);
                    return f;
                }
                return scalar<std::int32_t, std::uint32_t>(b, type);
            default: {
                double d;
                std::memcpy(&d, b, 8);
                return d;
            }
        }
    }
    std::size_t remaining() const { return body_.size() - pos_; }

private:
    static bool host_little_endian() {
        const std::uint16_t one = 1;
        unsigned char first;
        std::memcpy(&first, &one, 1);
        return first == 1;
    }
    template <class S, class U>
    static double scalar(const unsigned char* b, const PlyType& type) {
        if (type.is_signed) {
            S s;
            std::memcpy(&s, b, sizeof s);
            return s;
        }
        U u;
        std::memcpy(&u, b, sizeof u);
        return u;
    }
    SceneError truncated(const std::string& where) const {
        return SceneError(shown_, where, "file is truncated (the data ends inside it)");
    }

    std::string_view body_;
    PlyFormat format_;
    const std::string& shown_;
    std::size_t pos_ = 0;
};

// ---------------------------------------------------------------------------- OFF
// ASCII OFF and its variants with per-vertex extras (NOFF, COFF, STOFF: the first
// three numbers of a vertex line are its position, the rest is ignored), and binary
// OFF (big-endian int32 counts and indices, float32 coordinates). 4OFF (homogeneous)
// and nOFF (other dimensions) are refused.

// The lines of a text with '#' comments and blank lines left out, and where the
// text after them begins.
class TextLines {
public:
    explicit TextLines(std::string_view text) : text_(text) {}
    bool next(std::string& out) {
        while (pos_ < text_.size()) {
            auto end = text_.find('\n', pos_);
            if (end == std::string_view::npos) end = text_.size();
            out.assign(text_.substr(pos_, end - pos_));
            pos_ = end + 1;
            const auto hash = out.find('#');
            if (hash != std::string::npos) out.erase(hash);
            if (out.find_first_not_of(" \t\r") != std::string::npos) return true;
        }
        return false;
    }
    std::size_t remaining() const { return pos_ < text_.size() ? text_.size() - pos_ : 0; }
    std::size_t position() const { return std::min(pos_, text_.size()); }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
};

MeshData read_off(std::string_view content, const std::string& shown) {
    TextLines lines(content);
    std::string line;
    if (!lines.next(line)) throw SceneError(shown, "header", "empty file");
    std::istringstream hs(line);
    std::string magic;
    hs >> magic;
    const auto off = magic.rfind("OFF");
    if (off == std::string::npos || off + 3 != magic.size() ||
        magic.substr(0, off).find_first_not_of("STCN") != std::string::npos)
        throw SceneError(shown, "header", "not an OFF file ('" + magic + "'; known: OFF, NOFF, COFF, STOFF)");
    // "OFF BINARY", or the counts after the magic on its line or on the next.
    std::string rest = line.substr(line.find(magic) + magic.size());
    std::string first;
    std::istringstream(rest) >> first;
    const bool binary = first == "BINARY";
    MeshData data;
    if (binary) {
        PlyValues in(std::string_view(content).substr(lines.position()), PlyFormat::binary_be, shown);
        const PlyType int32 = ply_type("int32"), float32 = ply_type("float32");
        auto integer = [&](const std::string& where) {
            return static_cast<std::int32_t>(in.next(int32, [&] { return where; }));
        };
        const std::int32_t nv = integer("header"), nf = integer("header");
        integer("header");  // edges
        if (nv < 0 || nf < 0)
            throw SceneError(shown, "header", "negative vertex or face count (" + std::to_string(nv) + ", " +
                                                  std::to_string(nf) + ")");
        check_room(nv, 12, in.remaining(), shown, "vertices", "vertices");
        data.vertices.reserve(static_cast<std::size_t>(nv));
        for (std::int32_t i = 0; i < nv; ++i) {
            const std::string where = "vertex " + std::to_string(i);
            Vec3 p;
            for (int k = 0; k < 3; ++k) p[k] = in.next(float32, [&] { return where; });
            if (!p.allFinite()) throw SceneError(shown, where, "coordinate " + vector_text(p) + " is not finite");
            data.vertices.push_back(p);
        }
        check_room(nf, 16, in.remaining(), shown, "faces", "faces");
        std::vector<int> corners;
        for (std::int32_t i = 0; i < nf; ++i) {
            const std::string where = "face " + std::to_string(i);
            const std::int32_t k = integer(where);
            check_triangle_fan(k, shown, where);
            check_room(k, 4, in.remaining(), shown, where, "corners");
            corners.clear();
            for (std::int32_t c = 0; c < k; ++c) {
                const std::int32_t idx = integer(where);
                if (idx < 0 || idx >= nv)
                    throw SceneError(shown, where, "references vertex " + std::to_string(idx) + ", but the file has " +
                                                       std::to_string(nv) + " vertices");
                corners.push_back(idx);
            }
            const std::int32_t colours = integer(where);
            if (colours < 0 || colours > 4)
                throw SceneError(shown, where, "colour count " + std::to_string(colours) + " is not 0 to 4");
            for (std::int32_t c = 0; c < colours; ++c) in.next(float32, [&] { return where; });
            add_polygon(data, corners, shown, where);
        }
        return data;
    }

    if (first.empty() && !lines.next(rest)) throw SceneError(shown, "header", "missing vertex and face counts");
    std::istringstream cs(rest);
    std::string nv_text, nf_text;
    if (!(cs >> nv_text >> nf_text)) throw SceneError(shown, "header", "missing vertex and face counts");
    const long nv = parse_count(nv_text, shown, "header", "vertex count");
    const long nf = parse_count(nf_text, shown, "header", "face count");
    // A vertex line is at least "0 0 0\n", a face line (a malformed one) "3\n".
    check_room(nv, 6, lines.remaining(), shown, "vertices", "vertices");
    data.vertices.reserve(static_cast<std::size_t>(nv));
    for (long i = 0; i < nv; ++i) {
        if (!lines.next(line))
            throw SceneError(shown, "vertices",
                             "file is truncated: header promises " + std::to_string(nv) + " vertices, found " +
                                 std::to_string(i));
        data.vertices.push_back(read_coordinates(line, shown, "vertex " + std::to_string(i)));
    }
    check_room(nf, 2, lines.remaining(), shown, "faces", "faces");
    std::vector<int> corners;
    for (long i = 0; i < nf; ++i) {
        const std::string where = "face " + std::to_string(i);
        if (!lines.next(line))
            throw SceneError(shown, "faces",
                             "file is truncated: header promises " + std::to_string(nf) + " faces, found " +
                                 std::to_string(i));
        std::istringstream fs(line);
        std::string k_text;
        fs >> k_text;
        const long k = parse_count(k_text, shown, where, "corner count");
        check_triangle_fan(k, shown, where);
        check_room(k, 2, line.size() + 1, shown, where, "corners");  // "i " each, the last without the space
        corners.clear();
        for (long c = 0; c < k; ++c) {
            long idx = -1;
            if (!(fs >> idx))
                throw SceneError(shown, where, "has fewer than the " + std::to_string(k) + " indices it announces");
            if (idx < 0 || idx >= nv)
                throw SceneError(shown, where, "references vertex " + std::to_string(idx) + ", but the file has " +
                                                   std::to_string(nv) + " vertices");
            corners.push_back(static_cast<int>(idx));
        }
        add_polygon(data, corners, shown, where);
    }
    return data;
}

// ---------------------------------------------------------------------------- PLY
// ASCII, binary little- and big-endian. The vertex element gives x, y, z and,
// optionally, all of nx, ny, nz; the face element a list named vertex_indices (or
// vertex_index); other elements and properties are read past. Every count is checked
// against the bytes left before anything is allocated for it.

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
    std::vector<std::vector<int>> faces;
    std::vector<double> row;
    for (const auto& e : elements) {
        check_room(e.count, e.min_bytes(format), values.remaining(), shown, e.name,
                   e.name == "vertex" ? "vertices" : e.name == "face" ? "faces" : e.name + " elements");
        const bool is_vertex = &e == vertex, is_face = &e == face;
        if (is_vertex) {
            data.vertices.reserve(static_cast<std::size_t>(e.count));
            if (has_normals) normals.reserve(static_cast<std::size_t>(e.count));
        }
        if (is_face) faces.reserve(static_cast<std::size_t>(e.count));
        if (e.properties.empty()) continue;
        for (long i = 0; i < e.count; ++i) {
            const auto where = [&e, i] { return e.name + " " + std::to_string(i); };
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
            if (is_vertex) {
                const Vec3 p(row[xyz[0]], row[xyz[1]], row[xyz[2]]);
                if (!p.allFinite()) throw SceneError(shown, where(), "coordinate " + vector_text(p) + " is not finite");
                data.vertices.push_back(p);
                if (has_normals) {
                    const Vec3 n(row[nxyz[0]], row[nxyz[1]], row[nxyz[2]]);
                    if (!n.allFinite()) throw SceneError(shown, where(), "normal " + vector_text(n) + " is not finite");
                    if (!(n.norm() > 0.0)) throw SceneError(shown, where(), "normal " + vector_text(n) + " has zero length");
                    normals.push_back(n.normalized());
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
    }
    return data;
}

}  // namespace

namespace {

// Twice the signed area of the 2-D triangle (a, b, c): positive counter-clockwise.
double turn(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Whether the closed segments ab and cd meet.
bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                   const Eigen::Vector2d& d, double eps) {
    const double d1 = turn(a, b, c), d2 = turn(a, b, d), d3 = turn(c, d, a), d4 = turn(c, d, b);
    if (((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps)) && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps)))
        return true;
    // Touching: an end on the other segment.
    auto on = [eps](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, double t) {
        return std::abs(t) <= eps && r.x() >= std::min(p.x(), q.x()) - 1e-12 && r.x() <= std::max(p.x(), q.x()) + 1e-12 &&
               r.y() >= std::min(p.y(), q.y()) - 1e-12 && r.y() <= std::max(p.y(), q.y()) + 1e-12;
    };
    return on(a, b, c, d1) || on(a, b, d, d2) || on(c, d, a, d3) || on(c, d, b, d4);
}

}  // namespace

std::vector<std::array<int, 3>> triangulate_polygon(const std::vector<Vec3>& corners, double max_bend,
                                                    const std::string& shown, const std::string& where) {
    std::vector<std::array<int, 3>> fan;
    for (int k = 1; k + 1 < static_cast<int>(corners.size()); ++k) fan.push_back({0, k, k + 1});
    if (corners.size() <= 3) return fan;
    // A corner repeated next to itself adds nothing: the rest is cut, and the indices
    // mapped back.
    std::vector<int> index;
    for (int i = 0; i < static_cast<int>(corners.size()); ++i)
        if (index.empty() || corners[i] != corners[index.back()]) index.push_back(i);
    while (index.size() > 1 && corners[index.back()] == corners[index.front()]) index.pop_back();
    if (index.size() < 3) return fan;  // zero area: dropped on load
    std::vector<Vec3> p;
    for (int i : index) p.push_back(corners[i]);
    auto original = [&](std::vector<std::array<int, 3>> t) {
        for (auto& tri : t)
            for (int& k : tri) k = index[k];
        return t;
    };
    const int n = static_cast<int>(p.size());
    if (n == 3) return original({{0, 1, 2}});
    fan.clear();
    for (int k = 1; k + 1 < n; ++k) fan.push_back({0, k, k + 1});
    // Newell's normal (twice the vector area), the longest edge, the mean plane.
    Vec3 normal = Vec3::Zero(), mean = Vec3::Zero();
    double longest = 0.0;
    for (int i = 0; i < n; ++i) {
        const Vec3& a = p[i];
        const Vec3& b = p[(i + 1) % n];
        normal += a.cross(b);
        longest = std::max(longest, (b - a).norm());
        mean += a / n;
    }
    const double size = normal.norm();
    if (!(size > 1e-12 * longest * longest)) {
        // No area in all: a polygon on a line (its triangles dropped on load), or one
        // whose parts cancel (a symmetric bow tie), which crosses itself.
        for (const auto& t : fan)
            if ((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm() > 1e-9 * longest * longest)
                throw SceneError(shown, where,
                                 "a polygon of " + std::to_string(corners.size()) +
                                     " corners crosses itself (its parts' areas cancel)");
        return original(fan);
    }
    const Vec3 u = normal / size;
    int worst = 0;
    double bend = 0.0;
    for (int i = 0; i < n; ++i) {
        const double off = std::abs(u.dot(p[i] - mean));
        if (off > bend) bend = off, worst = index[i];
    }
    if (bend > max_bend * longest) {
        std::ostringstream why;
        why << "a polygon of " << corners.size() << " corners is not planar: corner " << worst << " lies " << bend
            << " off its plane, more than " << max_bend << " of its longest edge (" << longest << ")";
        throw SceneError(shown, where, why.str());
    }
    // In the plane, counter-clockwise (u is the polygon's own normal).
    const Vec3 ax = (std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(u).normalized();
    const Vec3 ay = u.cross(ax);
    std::vector<Eigen::Vector2d> q;
    for (const auto& x : p) q.emplace_back(ax.dot(x - mean), ay.dot(x - mean));
    const double eps = 1e-12 * longest * longest;
    for (int i = 0; i < n; ++i)
        for (int j = i + 2; j < n; ++j) {
            if (i == 0 && j == n - 1) continue;  // neighbours
            if (segments_meet(q[i], q[(i + 1) % n], q[j], q[(j + 1) % n], eps))
                throw SceneError(shown, where,
                                 "a polygon of " + std::to_string(corners.size()) +
                                     " corners crosses or touches itself (its edges from corners " + std::to_string(index[i]) +
                                     " and " + std::to_string(index[j]) + " meet)");
        }
    bool convex = true;
    for (int i = 0; i < n && convex; ++i) convex = turn(q[(i + n - 1) % n], q[i], q[(i + 1) % n]) >= -eps;
    if (convex) return original(fan);
    // Ear clipping: a corner that turns left and whose triangle holds no other corner.
    std::vector<int> left(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) left[i] = i;
    std::vector<std::array<int, 3>> out;
    while (left.size() > 3) {
        const int m = static_cast<int>(left.size());
        int ear = -1;
        for (int k = 0; k < m && ear < 0; ++k) {
            const int a = left[(k + m - 1) % m], b = left[k], c = left[(k + 1) % m];
            if (turn(q[a], q[b], q[c]) <= eps) continue;
            bool empty = true;
            for (int r : left) {
                if (r == a || r == b || r == c) continue;
                if (turn(q[a], q[b], q[r]) >= -eps && turn(q[b], q[c], q[r]) >= -eps && turn(q[c], q[a], q[r]) >= -eps) {
                    empty = false;
                    break;
                }
            }
            if (empty) ear = k;
        }
        if (ear < 0) ear = 0;  // only straight corners left: a zero-area triangle
        out.push_back({left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]});
        left.erase(left.begin() + ear);
    }
    out.push_back({left[0], left[1], left[2]});
    return original(out);
}

std::string read_input_file(const std::string& path, const std::string& shown, const std::string& kind,
                            std::uintmax_t max_bytes) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        throw SceneError(shown, "", "cannot open " + kind + " (" + std::strerror(errno) + ")");
    if (S_ISDIR(st.st_mode)) throw SceneError(shown, "", "is a directory, not a " + kind);
    if (!S_ISREG(st.st_mode))
        throw SceneError(shown, "", "is not a regular file (a FIFO, a socket or a device), not a " + kind);
    const auto size = static_cast<std::uintmax_t>(st.st_size);
    if (size > max_bytes)
        throw SceneError(shown, "", "is " + std::to_string(size) + " bytes, more than a " + kind + " may have (" +
                                        std::to_string(max_bytes) + ")");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(shown, "", "cannot open " + kind);
    std::string content(static_cast<std::size_t>(size), '\0');
    in.read(content.data(), static_cast<std::streamsize>(content.size()));
    content.resize(static_cast<std::size_t>(in.gcount()));
    return content;
}

MeshData read_mesh_file(const std::string& path, const std::string& shown) {
    const std::string ext = lower_extension(path);
    if (ext != "obj" && ext != "off" && ext != "ply")
        throw SceneError(shown, "", "unknown mesh format '." + ext + "' (known: .obj, .ply, .off)");
    return parse_mesh(read_input_file(path, shown, "mesh file", kMaxMeshFileBytes), ext, shown);
}

MeshData parse_mesh(std::string_view content, const std::string& format, const std::string& shown) {
    MeshData data;
    if (format == "obj") {
        std::istringstream in{std::string(content)};
        data = read_obj(in, shown);
    } else if (format == "off") {
        data = read_off(content, shown);
    } else if (format == "ply") {
        data = read_ply(content, shown);
    } else {
        throw SceneError(shown, "", "unknown mesh format '" + format + "' (known: obj, ply, off)");
    }
    if (data.triangles.empty()) throw SceneError(shown, "", "the mesh has no faces");
    if (data.vertices.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw SceneError(shown, "", "more than 2^31 vertices");
    return data;
}

}  // namespace raybundle::scenes
