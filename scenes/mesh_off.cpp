#include "scenes/mesh_readers.h"

#include <sstream>

namespace raybundle::scenes::mesh_detail {

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

}  // namespace raybundle::scenes::mesh_detail
