#pragma once
// What the mesh readers share (scenes/mesh_file.h is their interface): one file per
// format (mesh_obj.cpp, mesh_off.cpp, mesh_ply.cpp), the checks every count, index and
// polygon goes through (mesh_file.cpp), and the values of a PLY or binary OFF body.
// Internal to scenes/.
#include "scenes/errors.h"
#include "scenes/mesh_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace raybundle::scenes::mesh_detail {

// Parses three coordinates with strtod (which, unlike streams, reads "nan" and "inf")
// and throws if one is missing or not finite; `what` names them in the message
// ("vertex", "normal").
Vec3 read_coordinates(const std::string& text, const std::string& shown, const std::string& where,
                      const std::string& what = "vertex");
std::string vector_text(const Vec3& v);
// The warning for `count` normals without a direction (`kind`: "of zero length"), the
// first at `first` ("line 4").
std::string zero_normals_warning(const std::string& shown, long count, const std::string& first, const std::string& kind);
std::string lower_extension(const std::string& path);
// A count from a header: a whole number in [0, 2^31). "-3", "inf", "1e9" and
// "2147483648" are refused here rather than trusted until an allocation fails.
long parse_count(const std::string& text, const std::string& shown, const std::string& where,
                 const std::string& what);
// Refuses `count` elements of at least `each` bytes in `bytes` bytes (see mesh_file.cpp).
void check_room(long count, long each, std::size_t bytes, const std::string& shown, const std::string& where,
                const std::string& what);
void check_triangle_fan(long corners, const std::string& shown, const std::string& where);
// The most corners a polygon may have (add_polygon refuses more).
inline constexpr std::size_t kMaxPolygonCorners = 512;
// Adds the face's triangles (vertex indices) and returns them as positions in
// `corners` (for the corner normals).
std::vector<std::array<int, 3>> add_polygon(MeshData& data, const std::vector<int>& corners, const std::string& shown,
                                            const std::string& where);

// ------------------------------------------------------------- binary and text values
// The values of a PLY body (and of binary OFF, big-endian), one at a time.

enum class PlyFormat { ascii, binary_le, binary_be };

struct PlyType {
    int bytes = 0;  // 0: unknown
    bool real = false, is_signed = false;
};

inline PlyType ply_type(const std::string& name) {
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
            while (pos_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[pos_]))) {
                if (body_[pos_] == '\n' && row_ && in_row_)
                    throw SceneError(shown_, where(), "its line ends before its values do (" + *row_ + ")");
                ++pos_;
            }
            in_row_ = true;
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

    // An ASCII element is one line (the PLY format's rule): begin_row() before its first
    // value, end_row() after its last. A value on a later line, or one left on its line,
    // throws, with `what` (what the header says an element holds, and how many): a count
    // in the header that is not the file's would otherwise read values across lines and
    // be reported as some later element's error ("face 0: face has 2 corners"). No-ops
    // in the binary formats.
    void begin_row(const std::string& what) {
        row_ = &what;
        in_row_ = false;
    }
    template <class Where>
    void end_row(const Where& where) {
        if (format_ != PlyFormat::ascii || !row_) return;
        std::size_t at = pos_;
        while (at < body_.size() && body_[at] != '\n' && std::isspace(static_cast<unsigned char>(body_[at]))) ++at;
        if (at < body_.size() && body_[at] != '\n')
            throw SceneError(shown_, where(), "its line holds more values than the header gives it (" + *row_ + ")");
    }

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
    const std::string* row_ = nullptr;  // begin_row()'s `what`
    bool in_row_ = false;                // a value of the row read
    SceneError truncated(const std::string& where) const {
        return SceneError(shown_, where, "file is truncated (the data ends inside it)");
    }

    std::string_view body_;
    PlyFormat format_;
    const std::string& shown_;
    std::size_t pos_ = 0;
};

// The readers, one file each.
MeshData read_obj(std::istream& in, const std::string& shown);
MeshData read_off(std::string_view content, const std::string& shown);
MeshData read_ply(std::string_view content, const std::string& shown);
// glTF 2.0 (scenes/mesh_gltf.cpp); `folder` holds the files its URIs name (none:
// a buffer or image in another file is refused).
inline constexpr std::uintmax_t kMaxGltfFileBytes = (std::uintmax_t{1} << 31) - 1;
MeshData read_gltf(std::string_view content, bool binary, const std::string& shown,
                   const std::optional<std::string>& folder, std::size_t max_triangles);

// Where albedo + specular reaches 1 in a channel, or a texture's brightest texels times
// its tint plus specular pass 1 (the albedo and the texels times brightest_colour, the
// most the vertex colours of its triangles multiply them by), scales them (and the tint) so that the most is 0.99 (a
// surface reflects less than it receives) and returns the sum it had there and its
// channel (0, 1, 2), for the caller's warning; nothing when neither was
// (scenes/mesh_materials.cpp).
std::optional<std::pair<double, int>> keep_energy(Material& m, const Rgb& brightest_colour);


}  // namespace raybundle::scenes::mesh_detail
