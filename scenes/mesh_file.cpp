#include "scenes/mesh_file.h"

#include "scenes/errors.h"
#include "scenes/mesh_readers.h"

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

namespace mesh_detail {

// Parses three coordinates with strtod (which, unlike streams, reads "nan" and "inf")
// and throws if one is missing, not finite or not a whole word ("0.5x"), or where a
// word after them is not a number (an OBJ's w or vertex colour, an OFF's colour or
// texture coordinates are; a '#' ends the line); `what` names them in the message
// ("vertex", "normal").
Vec3 read_coordinates(const std::string& text, const std::string& shown, const std::string& where,
                      const std::string& what) {
    const char* p = text.c_str();
    const auto ends_word = [](char c) { return c == '\0' || c == ' ' || c == '\t' || c == '\r' || c == '#'; };
    const auto word_at = [&ends_word](const char* from) {
        const char* to = from;
        while (!ends_word(*to)) ++to;
        return std::string(from, to);
    };
    const std::string named = what == "vertex" ? "" : what + " ";
    Vec3 r;
    for (int k = 0; k < 3; ++k) {
        char* end = nullptr;
        while (*p == ' ' || *p == '\t') ++p;
        const double x = std::strtod(p, &end);
        if (end == p && ends_word(*p)) throw SceneError(shown, where, what + " has fewer than 3 coordinates");
        if (end == p || !ends_word(*end))
            throw SceneError(shown, where, named + "coordinate '" + word_at(p) + "' is not a number");
        if (!std::isfinite(x))
            throw SceneError(shown, where, named + "coordinate '" + std::string(p, static_cast<const char*>(end)) +
                                               "' is not finite");
        r[k] = x;
        p = end;
    }
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == '\r') ++p;
        if (*p == '\0' || *p == '#') return r;
        char* end = nullptr;
        std::strtod(p, &end);
        if (end == p || !ends_word(*end))
            throw SceneError(shown, where, "'" + word_at(p) + "' after the " + what + "'s coordinates is not a number");
        p = end;
    }
}

std::string vector_text(const Vec3& v) {
    std::ostringstream os;
    os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    return os.str();
}

std::string zero_normals_warning(const std::string& shown, long count, const std::string& first, const std::string& kind) {
    return shown + ": " + (count == 1 ? "a normal " : std::to_string(count) + " normals ") + kind + " (" +
           (count == 1 ? "" : "the first ") + "at " + first + "): the corners that use " +
           (count == 1 ? "it get a computed normal" : "them get computed normals");
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
    // The crossing test and ear clipping take time quadratic in the corners (1,000
    // corners: seconds): a larger polygon is refused rather than left to run.
    if (corners.size() > kMaxPolygonCorners)
        throw SceneError(shown, where,
                         "face has " + std::to_string(corners.size()) + " corners, at most " +
                             std::to_string(kMaxPolygonCorners) + " (triangulate it in the modeller)");
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

}  // namespace mesh_detail

using namespace mesh_detail;

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
    if (ext == "gltf" || ext == "glb") {
        // tinygltf takes the size as 32 bits.
        const auto slash = path.find_last_of('/');
        MeshData data = read_gltf(read_input_file(path, shown, "mesh file", kMaxGltfFileBytes), ext == "glb", shown,
                                  slash == std::string::npos ? std::string(".") : path.substr(0, slash),
                                  kMaxMeshTriangles);
        return data;
    }
    if (ext != "obj" && ext != "off" && ext != "ply")
        throw SceneError(shown, "", "unknown mesh format '." + ext + "' (known: .obj, .ply, .off, .gltf, .glb)");
    return parse_mesh(read_input_file(path, shown, "mesh file", kMaxMeshFileBytes), ext, shown);
}

MeshData parse_mesh(std::string_view content, const std::string& format, const std::string& shown,
                    std::size_t max_triangles) {
    MeshData data;
    if (format == "gltf" || format == "glb") {
        if (content.size() > kMaxGltfFileBytes) throw SceneError(shown, "", "a glTF file of more than 2 GiB");
        data = read_gltf(content, format == "glb", shown, std::nullopt, max_triangles);
    } else if (format == "obj") {
        std::istringstream in{std::string(content)};
        data = read_obj(in, shown);
    } else if (format == "off") {
        data = read_off(content, shown);
    } else if (format == "ply") {
        data = read_ply(content, shown);
    } else {
        throw SceneError(shown, "", "unknown mesh format '" + format + "' (known: obj, ply, off, gltf, glb)");
    }
    if (data.triangles.empty()) throw SceneError(shown, "", "the mesh has no faces");
    if (data.vertices.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw SceneError(shown, "", "more than 2^31 vertices");
    return data;
}

}  // namespace raybundle::scenes
