#include "scenes/loader.h"

#include "scenes/builtin.h"
#include "scenes/mesh_file.h"
#include "scenes/errors.h"
#include "scenes/contacts.h"
#include "scenes/subdivide.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

namespace raybundle::scenes {
namespace {

using json = nlohmann::json;

std::string format_number(double x) {
    std::ostringstream os;
    os << x;
    return os.str();
}

const char* type_name(const json& j) { return j.type_name(); }

// The largest magnitude of a coordinate, colour or intensity: beyond it products
// (areas, depths, irradiance) overflow or reach the float image's range.
constexpr double kMaxMagnitude = 1e15;

// Text for an error message, cut to at most `n` characters ("..." at the end if cut).
std::string cut(std::string text, std::size_t n) {
    if (text.size() > n) text = text.substr(0, n - 3) + "...";
    return text;
}

// A value as an error message shows it: its JSON, cut after 60 characters.
std::string shown_value(const json& j) { return cut(j.dump(), 60); }

// JSON as the scene format takes it: at most kMaxJsonDepth containers deep (a deeper
// document is refused while it is read, before it is built) and no key twice in one
// object (JSON allows it, and the last one would silently win).
constexpr std::size_t kMaxJsonDepth = 64;

json parse_json(const std::string& text, const std::string& shown) {
    struct Open {
        bool object;
        std::size_t index = 0;          // arrays: the element being read
        std::string key;                // objects: the key being read
        std::vector<std::string> keys;  // objects: the keys seen
    };
    std::vector<Open> open;
    auto path = [&open] {
        std::string p;
        for (std::size_t i = 0; i + 1 < open.size(); ++i)
            p += open[i].object ? (p.empty() ? "" : ".") + open[i].key : "[" + std::to_string(open[i].index) + "]";
        return p;
    };
    auto value_done = [&open] {
        if (!open.empty() && !open.back().object) ++open.back().index;
    };
    const json::parser_callback_t callback = [&](int, json::parse_event_t event, json& parsed) {
        switch (event) {
            case json::parse_event_t::object_start:
            case json::parse_event_t::array_start:
                if (open.size() >= kMaxJsonDepth)
                    throw SceneError(shown, path(), "nested more than " + std::to_string(kMaxJsonDepth) + " deep");
                open.push_back({event == json::parse_event_t::object_start, 0, {}, {}});
                break;
            case json::parse_event_t::key: {
                Open& top = open.back();
                top.key = parsed.get<std::string>();
                if (std::find(top.keys.begin(), top.keys.end(), top.key) != top.keys.end()) {
                    const std::string where = path();
                    throw SceneError(shown, where.empty() ? top.key : where + "." + top.key, "key given twice");
                }
                top.keys.push_back(top.key);
                break;
            }
            case json::parse_event_t::object_end:
            case json::parse_event_t::array_end:
                open.pop_back();
                value_done();
                break;
            case json::parse_event_t::value:
                value_done();
                break;
        }
        return true;
    };
    return json::parse(text, callback);
}

// A JSON object with its path in the file: typed getters that throw SceneError, and
// a check that every key present is one we know (a typo is an error, not a default).
class Node {
public:
    Node(const json& j, std::string file, std::string path) : j_(j), file_(std::move(file)), path_(std::move(path)) {}

    const std::string& path() const { return path_; }
    std::string at(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
    bool has(const std::string& key) const { return j_.contains(key); }
    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw SceneError(file_, key.empty() ? path_ : at(key), what);
    }

    void require_object() const {
        if (!j_.is_object()) throw SceneError(file_, path_, std::string("expected an object, got ") + type_name(j_));
    }

    void check_keys(std::initializer_list<const char*> known) const {
        for (auto it = j_.begin(); it != j_.end(); ++it) {
            bool ok = false;
            for (const char* k : known) ok = ok || it.key() == k;
            if (!ok) {
                std::string list;
                for (const char* k : known) list += (list.empty() ? "" : ", ") + std::string(k);
                fail("", "unknown key '" + it.key() + "' (known: " + list + ")");
            }
        }
    }

    const json& raw(const std::string& key) const {
        if (!j_.contains(key)) fail(key, "missing");
        return j_.at(key);
    }

    double number(const std::string& key) const {
        const json& v = raw(key);
        if (!v.is_number()) fail(key, std::string("expected a number, got ") + type_name(v));
        const double x = v.get<double>();
        if (!std::isfinite(x)) fail(key, "value " + format_number(x) + " is not finite");
        return x;
    }

    int integer(const std::string& key) const {
        const json& v = raw(key);
        if (!v.is_number_integer()) fail(key, std::string("expected an integer, got ") + shown_value(v));
        // Range-check before narrowing: a large value must not wrap into a valid one.
        const bool in_range = v.is_number_unsigned() ? v.get<unsigned long long>() <= 1000000000ull
                                                      : v.get<long long>() >= -1000000000ll &&
                                                            v.get<long long>() <= 1000000000ll;
        if (!in_range) fail(key, "value " + shown_value(v) + " is out of range");
        return static_cast<int>(v.get<long long>());
    }

    bool boolean(const std::string& key) const {
        const json& v = raw(key);
        if (!v.is_boolean()) fail(key, std::string("expected true or false, got ") + shown_value(v));
        return v.get<bool>();
    }

    std::string string(const std::string& key) const {
        const json& v = raw(key);
        if (!v.is_string()) fail(key, std::string("expected a string, got ") + type_name(v));
        return v.get<std::string>();
    }

    Vec3 vec3(const json& v, const std::string& where) const {
        if (!v.is_array() || v.size() != 3) throw SceneError(file_, where, "expected [x, y, z], got " + shown_value(v));
        Vec3 r;
        for (int k = 0; k < 3; ++k) {
            if (!v[k].is_number()) throw SceneError(file_, where, "expected [x, y, z], got " + shown_value(v));
            r[k] = v[k].get<double>();
            if (!std::isfinite(r[k]))
                throw SceneError(file_, where, "coordinate " + format_number(r[k]) + " is not finite");
            if (std::abs(r[k]) > kMaxMagnitude)
                throw SceneError(file_, where, "value " + format_number(r[k]) + " is too large (at most " +
                                                   format_number(kMaxMagnitude) + " in magnitude)");
        }
        return r;
    }
    Vec3 vec3(const std::string& key) const { return vec3(raw(key), at(key)); }

    Node child(const std::string& key) const { return Node(raw(key), file_, at(key)); }
    const json& value() const { return j_; }
    const std::string& file() const { return file_; }

private:
    const json& j_;
    std::string file_;
    std::string path_;
};

// The triangles turned over (the twins of a two-sided material).
std::vector<std::array<int, 3>> reversed(std::vector<std::array<int, 3>> tris) {
    for (auto& t : tris) std::swap(t[1], t[2]);
    return tris;
}

// A mesh object's placement: "scale" (a number or [sx, sy, sz], none 0: negative
// mirrors), "rotate" ([x, y, z] degrees about the axes, x first), "translate" ([x, y,
// z]), applied in that order to its vertices, normals and lights. A mirror
// turns its triangles round, so that their fronts stay their fronts.
void place_mesh(const Node& obj, MeshData& data) {
    Vec3 scale = Vec3::Ones();
    if (obj.has("scale")) {
        const json& s = obj.raw("scale");
        scale = s.is_number() ? obj.vec3(json::array({s, s, s}), obj.at("scale")) : obj.vec3("scale");
        if ((scale.array() == 0.0).any())
            obj.fail("scale", "a factor of 0 flattens the mesh, got " + shown_value(s));
    }
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    if (obj.has("rotate")) {
        const Vec3 degrees = obj.vec3("rotate");
        for (int axis = 0; axis < 3; ++axis)
            rotation = Eigen::AngleAxisd(degrees[axis] * M_PI / 180.0, Vec3::Unit(axis)).toRotationMatrix() * rotation;
    }
    const Vec3 offset = obj.has("translate") ? obj.vec3("translate") : Vec3::Zero();
    const Eigen::Matrix3d linear = rotation * scale.asDiagonal();
    const Eigen::Matrix3d normal_matrix = rotation * scale.cwiseInverse().asDiagonal();
    for (auto& v : data.vertices) v = linear * v + offset;
    for (auto& corners : data.normals)
        for (auto& n : corners)
            if (n != Vec3::Zero()) n = (normal_matrix * n).normalized();
    for (auto& light : data.point_lights) {
        light.position = linear * light.position + offset;
        if (light.spot()) light.axis = (linear * light.axis).normalized();  // (its cone as it was)
    }
    for (auto& light : data.directional_lights) light.direction = (linear * light.direction).normalized();
    if (data.camera) {
        data.camera->eye = linear * data.camera->eye + offset;
        data.camera->target = linear * data.camera->target + offset;
        data.camera->up = (linear * data.camera->up).normalized();
    }
    if (linear.determinant() < 0.0) {
        for (auto& t : data.triangles) std::swap(t[1], t[2]);
        for (auto& corners : data.normals) std::swap(corners[1], corners[2]);
        for (auto& corners : data.uvs) std::swap(corners[1], corners[2]);
        for (auto& corners : data.colours) std::swap(corners[1], corners[2]);
    }
}

// A mesh's vertices at the same place made one (as exporters write flat-shaded meshes
// and scans: a vertex per face corner). Its triangles then share their edges, so that
// its surface is one (computed normals smooth across its edges within the crease
// angle; the file's normals stay per corner) and the contacts it makes are those of
// its outline, not of every triangle's edges. The first of equal vertices is kept;
// returns how many were merged.
std::size_t weld(MeshData& data) {
    const std::size_t n = data.vertices.size();
    struct Keyed {
        std::array<double, 3> at;
        std::uint32_t index;
        bool operator<(const Keyed& o) const { return at != o.at ? at < o.at : index < o.index; }
    };
    std::vector<Keyed> order(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3& v = data.vertices[i];
        order[i] = {{v.x(), v.y(), v.z()}, static_cast<std::uint32_t>(i)};
    }
    std::sort(order.begin(), order.end());
    std::vector<int> first(n);
    std::size_t merged = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const bool same = k > 0 && order[k].at == order[k - 1].at;
        first[order[k].index] = same ? first[order[k - 1].index] : static_cast<int>(order[k].index);
        merged += same;
    }
    if (merged == 0) return 0;
    // Kept vertices in their order, the triangles renumbered.
    std::vector<int> index(n, -1);
    std::vector<Vec3> kept;
    kept.reserve(n - merged);
    for (std::size_t i = 0; i < n; ++i)
        if (first[i] == static_cast<int>(i)) index[i] = static_cast<int>(kept.size()), kept.push_back(data.vertices[i]);
    for (auto& t : data.triangles)
        for (int& c : t) c = index[static_cast<std::size_t>(first[static_cast<std::size_t>(c)])];
    data.vertices = std::move(kept);
    return merged;
}

std::string rgb_text(const Rgb& c) {
    return "[" + format_number(c[0]) + ", " + format_number(c[1]) + ", " + format_number(c[2]) + "]";
}

Material parse_material(const Node& n, const std::string& name) {
    n.require_object();
    n.check_keys({"albedo", "emission", "specular", "exponent", "two_sided"});
    Material m;
    m.name = name;
    m.albedo = n.vec3("albedo").array();
    if (n.has("emission")) m.emission = n.vec3("emission").array();
    if (n.has("specular")) m.specular = n.vec3("specular").array();
    if (n.has("exponent")) m.exponent = n.number("exponent");
    if (n.has("two_sided")) m.two_sided = n.boolean("two_sided");
    if ((m.albedo < 0).any()) n.fail("albedo", "negative albedo " + rgb_text(m.albedo));
    if ((m.specular < 0).any()) n.fail("specular", "negative specular " + rgb_text(m.specular));
    if ((m.emission < 0).any()) n.fail("emission", "negative emission " + rgb_text(m.emission));
    if (m.exponent < 0) n.fail("exponent", "negative exponent " + format_number(m.exponent));
    if (m.glossy() && !n.has("exponent")) n.fail("exponent", "missing (a material with specular needs it)");
    static const char* channel[3] = {"r", "g", "b"};
    for (int k = 0; k < 3; ++k) {
        const double sum = m.albedo[k] + m.specular[k];
        if (!(sum < 1.0))
            n.fail("", "albedo + specular = " + format_number(sum) + " in channel " + channel[k] +
                           " (must be < 1 so that the light transport contracts)");
    }
    return m;
}

Camera parse_camera(const Node& n) {
    n.require_object();
    n.check_keys({"eye", "target", "up", "fov_y", "width", "height"});
    Camera c;
    c.eye = n.vec3("eye");
    c.target = n.vec3("target");
    if (n.has("up")) c.up = n.vec3("up");
    if (n.has("fov_y")) c.fov_y = n.number("fov_y");
    if (n.has("width")) c.width = n.integer("width");
    if (n.has("height")) c.height = n.integer("height");
    if (!(c.fov_y > 0.0 && c.fov_y < 180.0))
        n.fail("fov_y", "must be in (0, 180) degrees, got " + format_number(c.fov_y));
    if (c.width <= 0 || c.width > 16384) n.fail("width", "must be in 1..16384, got " + std::to_string(c.width));
    if (c.height <= 0 || c.height > 16384) n.fail("height", "must be in 1..16384, got " + std::to_string(c.height));
    const Vec3 view = c.target - c.eye;
    if (view.norm() == 0.0) n.fail("target", "equals the eye");
    if (c.up.cross(view).norm() <= 1e-9 * c.up.norm() * view.norm())
        n.fail("up", "is zero or parallel to the viewing direction");
    return c;
}

// A point light; with "direction", a spot of "outer_angle" and "inner_angle" (degrees
// from its axis; 45 and 0 by default, as glTF's).
PointLight parse_point_light(const Node& n) {
    n.require_object();
    n.check_keys({"position", "intensity", "direction", "inner_angle", "outer_angle"});
    PointLight l;
    l.position = n.vec3("position");
    l.intensity = n.vec3("intensity").array();
    if ((l.intensity < 0).any()) n.fail("intensity", "negative intensity " + rgb_text(l.intensity));
    if (!n.has("direction")) {
        for (const char* key : {"inner_angle", "outer_angle"})
            if (n.has(key)) n.fail(key, "a cone needs the spot's \"direction\"");
        return l;
    }
    const Vec3 axis = n.vec3("direction");
    const double longest = axis.cwiseAbs().maxCoeff();
    if (!(longest > 0.0)) n.fail("direction", "must be a direction, not " + rgb_text(axis.array()));
    l.axis = (axis / longest).normalized();
    const double outer = n.has("outer_angle") ? n.number("outer_angle") : 45.0;
    const double inner = n.has("inner_angle") ? n.number("inner_angle") : 0.0;
    if (!(outer > 0.0 && outer <= 180.0)) n.fail("outer_angle", "must be in (0, 180] degrees, got " + format_number(outer));
    if (!(inner >= 0.0 && inner <= outer))
        n.fail("inner_angle", "must be in [0, outer_angle = " + format_number(outer) + "] degrees, got " + format_number(inner));
    l.cos_outer = std::cos(outer * M_PI / 180.0);
    l.cos_inner = std::cos(inner * M_PI / 180.0);
    return l;
}

// A directional light: parallel light travelling along "direction", of "irradiance"
// on a surface facing it.
DirectionalLight parse_directional_light(const Node& n) {
    n.require_object();
    n.check_keys({"direction", "irradiance"});
    DirectionalLight l;
    const Vec3 direction = n.vec3("direction");
    const double longest = direction.cwiseAbs().maxCoeff();  // (scaled first: [1e-200, 0, 0] is a direction)
    if (!(longest > 0.0)) n.fail("direction", "must be a direction, not " + rgb_text(direction.array()));
    l.direction = (direction / longest).normalized();
    l.irradiance = n.vec3("irradiance").array();
    if ((l.irradiance < 0).any()) n.fail("irradiance", "negative irradiance " + rgb_text(l.irradiance));
    l.name = n.path();  // "directional_lights[i]"
    return l;
}

Sky parse_sky(const Node& n) {
    n.require_object();
    n.check_keys({"radiance", "up", "model"});
    Sky s;
    s.radiance = n.vec3("radiance").array();
    if ((s.radiance < 0).any()) n.fail("radiance", "negative radiance " + rgb_text(s.radiance));
    if (n.has("up")) {
        const Vec3 up = n.vec3("up");
        if (!(up.norm() > 0.0)) n.fail("up", "is the zero vector");
        s.up = up.normalized();
    }
    if (n.has("model")) {
        const std::string model = n.string("model");
        if (model == "constant")
            s.model = Sky::Model::constant;
        else if (model == "overcast")
            s.model = Sky::Model::overcast;
        else
            n.fail("model", "unknown sky model '" + model + "' (known: constant, overcast)");
    }
    return s;
}

// A crease angle in degrees, 0 (flat) to 180 (every patch around a vertex counts).
double crease_angle(const Node& n) {
    const double a = n.number("crease_angle");
    if (!(a >= 0.0 && a <= 180.0)) n.fail("crease_angle", "must be in [0, 180] degrees, got " + format_number(a));
    return a;
}

json camera_json(const Camera& c) {
    auto v = [](const Vec3& p) { return json::array({p.x(), p.y(), p.z()}); };
    return {{"eye", v(c.eye)}, {"target", v(c.target)}, {"up", v(c.up)},
            {"fov_y", c.fov_y}, {"width", c.width}, {"height", c.height}};
}

// A setting of one of the image's sides (applied after the others: follow_aspect).
bool image_side(const Override& o) { return o.key == "camera.width" || o.key == "camera.height"; }

// One side of the image given (--width 64, -D camera.height=...): the other follows the
// camera's aspect, its sides in `before` (the camera as the other settings made it; 512
// where absent, as Camera's): a smaller image of the same view, not a 64 x 512 sliver.
// Both given, both hold. `camera` is the camera's document after the settings; a side
// past 16384 is refused, naming the one given.
void follow_aspect(json& camera, const json& before, const Overrides& overrides, const std::string& shown) {
    const auto given = [&](const char* key) {
        return std::any_of(overrides.begin(), overrides.end(), [&](const Override& o) { return o.key == key; });
    };
    const bool width = given("camera.width");
    if (width == given("camera.height")) return;
    const char* side = width ? "width" : "height";
    const char* other = width ? "height" : "width";
    const auto side_of = [&](const char* key) {
        return before.is_object() && before.contains(key) && before[key].is_number() ? before[key].get<double>() : 512.0;
    };
    if (!camera.is_object() || !camera.contains(side) || !camera[side].is_number_integer() || !(side_of(side) > 0.0))
        return;  // parse_camera names what is wrong with it
    const double scaled = std::max(1.0, std::round(side_of(other) * camera[side].get<double>() / side_of(side)));
    if (scaled > 16384.0)
        throw SceneError(shown, std::string("camera.") + side,
                         std::string(side) + " " + std::to_string(camera[side].get<long long>()) + " makes the " + other +
                             " " + format_number(scaled) + " at the camera's aspect, past 16384: give both sides");
    camera[other] = static_cast<int>(scaled);
}

// Sets doc at the path `key` (dots between object keys, [i] for array elements, ["k"]
// for a key with dots or brackets of its own) to `text` read as JSON, or as a string
// when it is not JSON.
void apply_override(json& doc, const Override& o, const std::string& shown) {
    if (o.key.empty()) throw SceneError(shown, "", "an override needs a key (-D key=value)");
    json value;
    try {
        value = parse_json(o.value, shown);
    } catch (const SceneError& e) {  // a key given twice, or nested too deep: where, below the key
        const std::string& below = e.where();
        throw SceneError(shown, below.empty() ? o.key : o.key + (below[0] == '[' ? "" : ".") + below,
                         e.problem() + " (from -D " + o.key + "=" + cut(o.value, 200) + ")");
    } catch (const json::out_of_range& e) {  // a number a double cannot hold: 1e400
        std::string msg = e.what();
        const auto bracket = msg.find("] ");
        if (bracket != std::string::npos) msg = msg.substr(bracket + 2);
        throw SceneError(shown, o.key, cut(msg, 200));
    } catch (const json::exception&) {
        value = o.value;  // a bare word: a string
    }
    json* node = &doc;
    std::size_t pos = 0;
    while (pos < o.key.size()) {
        const std::size_t end = o.key.find_first_of(".[", pos);
        const std::string part = o.key.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
        const std::string so_far = o.key.substr(0, end == std::string::npos ? o.key.size() : end);
        if (!part.empty()) {
            if (node->is_null()) *node = json::object();
            if (!node->is_object()) throw SceneError(shown, so_far, "cannot set: not an object (-D " + o.key + ")");
            node = &(*node)[part];
        }
        if (end == std::string::npos) break;
        if (o.key.compare(end, 2, "[\"") == 0) {
            // ["name"]: an object key of any characters but `"]` (a material "Material (b.obj)").
            const std::size_t close = o.key.find("\"]", end + 2);
            if (close == std::string::npos) throw SceneError(shown, o.key, "malformed key in -D " + o.key + " (no closing \"])");
            if (close == end + 2) throw SceneError(shown, o.key, "malformed key in -D " + o.key + " (an empty name)");
            if (close + 2 < o.key.size() && o.key[close + 2] != '.' && o.key[close + 2] != '[')
                throw SceneError(shown, o.key, "malformed key in -D " + o.key + " (a '.' or '[' after \"])");
            if (node->is_null()) *node = json::object();
            if (!node->is_object())
                throw SceneError(shown, o.key.substr(0, end), "cannot set: not an object (-D " + o.key + ")");
            node = &(*node)[o.key.substr(end + 2, close - end - 2)];
            pos = close + 2;
            if (pos < o.key.size() && o.key[pos] == '.') ++pos;
        } else if (o.key[end] == '[') {
            const std::size_t close = o.key.find(']', end);
            const std::string digits = close == std::string::npos ? "" : o.key.substr(end + 1, close - end - 1);
            // Digits only, and few enough to be a number (the array check below bounds it).
            if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9)
                throw SceneError(shown, o.key, "malformed index in -D " + o.key);
            const std::size_t i = std::stoul(digits);
            if (!node->is_array() || i >= node->size())
                throw SceneError(shown, o.key.substr(0, close + 1), "no such element (-D " + o.key + ")");
            node = &(*node)[i];
            pos = close + 1;
            if (pos < o.key.size() && o.key[pos] == '.') ++pos;
        } else {
            pos = end + 1;
        }
    }
    *node = value;
}

// A textured material on triangles without texture coordinates (`uvs` empty, or NaN
// where a triangle has none): its mean colour there, with a warning.
void warn_without_uvs(Scene& scene, const std::string& object_name, int material, std::size_t triangles,
                      const std::vector<std::array<Uv, 3>>& uvs) {
    const Material& m = scene.materials[static_cast<std::size_t>(material)];
    if (!m.texture) return;
    const auto bare = uvs.empty() ? triangles : static_cast<std::size_t>(std::count_if(uvs.begin(), uvs.end(), [](const auto& c) {
        return !(c[0].allFinite() && c[1].allFinite() && c[2].allFinite());
    }));
    if (bare == 0) return;
    const Rgb mean = m.texture->mean();
    scene.warnings.push_back(object_name + ": " + std::to_string(bare) + " of " + std::to_string(triangles) +
                             " triangles give no texture coordinates: there its texture " + m.texture->shown +
                             " is read as its mean colour " + format_number(mean[0]) + " " + format_number(mean[1]) +
                             " " + format_number(mean[2]));
}

// A mesh that brings its materials: one object per material and group (OBJ `o`/`g`),
// named by the material, or by "group/material" where a material is used in several
// groups (a group statement may come before or after its faces: material names are the
// names files get right); the faces of two-sided materials get their twins. `name`
// begins each object's name: "objects[2] (box.obj" gets ": floor)", a name given by
// the scene gets ": floor".
void add_mesh_groups(Scene& scene, const MeshData& data, const std::vector<int>& materials, const std::string& name,
                     bool given, double crease) {
    // The (material, group) pairs in order of first use, each with its triangles: one
    // pass over the mesh, whatever the number of parts.
    std::vector<std::pair<int, int>> parts;
    std::vector<std::vector<std::size_t>> members;
    std::map<std::pair<int, int>, std::size_t> part_of;
    for (std::size_t t = 0; t < data.triangles.size(); ++t) {
        const std::pair<int, int> key(materials[t], data.triangle_group.empty() ? -1 : data.triangle_group[t]);
        const auto [it, added] = part_of.emplace(key, parts.size());
        if (added) parts.push_back(key), members.emplace_back();
        members[it->second].push_back(t);
    }
    // A vertex's index in the part being made (`owner` says which part set it).
    std::vector<int> remap(data.vertices.size(), -1), owner(data.vertices.size(), -1);
    for (std::size_t p = 0; p < parts.size(); ++p) {
        const auto [mat, group] = parts[p];
        std::vector<std::array<int, 3>> tris, twins;
        std::vector<std::array<Vec3, 3>> normals, twin_normals;
        std::vector<std::array<Uv, 3>> uvs, twin_uvs;
        std::vector<std::array<Rgb, 3>> colours, twin_colours;
        std::vector<Vec3> vertices;
        for (const std::size_t t : members[p]) {
            std::array<int, 3> tri{};
            for (int k = 0; k < 3; ++k) {
                const auto v = static_cast<std::size_t>(data.triangles[t][k]);
                if (owner[v] != static_cast<int>(p)) {
                    owner[v] = static_cast<int>(p);
                    remap[v] = static_cast<int>(vertices.size());
                    vertices.push_back(data.vertices[v]);
                }
                tri[k] = remap[v];
            }
            tris.push_back(tri);
            if (!data.normals.empty()) normals.push_back(data.normals[t]);
            if (!data.uvs.empty()) uvs.push_back(data.uvs[t]);
            if (!data.colours.empty()) colours.push_back(data.colours[t]);
            if (scene.materials[static_cast<std::size_t>(mat)].two_sided) {
                twins.push_back({tri[0], tri[2], tri[1]});
                if (!data.normals.empty())
                    twin_normals.push_back({-data.normals[t][0], -data.normals[t][2], -data.normals[t][1]});
                if (!data.uvs.empty()) twin_uvs.push_back({data.uvs[t][0], data.uvs[t][2], data.uvs[t][1]});
                if (!data.colours.empty())
                    twin_colours.push_back({data.colours[t][0], data.colours[t][2], data.colours[t][1]});
            }
        }
        const auto groups_of_mat = std::count_if(parts.begin(), parts.end(), [m = mat](const auto& other) { return other.first == m; });
        std::string part = scene.materials[static_cast<std::size_t>(mat)].name;
        if (groups_of_mat > 1) part = (group < 0 ? std::string("(no group)") : data.groups[static_cast<std::size_t>(group)]) + "/" + part;
        const std::string object_name = given ? name + ": " + part : name + ": " + part + ")";
        warn_without_uvs(scene, object_name, mat, tris.size(), uvs);
        const int id = scene.add_object(vertices, tris, mat, object_name, -1, normals, uvs, colours);
        if (!twins.empty()) scene.add_object(vertices, twins, mat, "", id, twin_normals, twin_uvs, twin_colours);
        scene.crease_angles[static_cast<std::size_t>(id)] = crease;
    }
}

std::string dir_of(const std::string& path) {
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? "." : path.substr(0, slash);
}

}  // namespace

namespace {

// The scene's "patch_size": a number refines to it; "auto" (or no entry) to 1/25 of the
// scene's largest extent, so that a room modelled with one quad a wall is not solved
// as a dozen patches; "none" keeps the patches as modelled. Records the decision.
void refine(Scene& scene, const Node& root, const std::string& shown, const LoadLimits& limits, Finish finish) {
    const PatchBudget budget = patch_budget(limits.max_patches, limits.memory);
    double size = 0.0;
    if (root.has("patch_size") && root.raw("patch_size").is_string()) {
        const std::string word = root.string("patch_size");
        if (word == "none") {
            scene.refinement = "none: the patches as modelled (\"patch_size\": \"none\")";
            return;
        }
        if (word != "auto") root.fail("patch_size", "expected a number, \"auto\" or \"none\", got \"" + cut(word, 40) + "\"");
    }
    if (root.has("patch_size") && !root.raw("patch_size").is_string()) {
        size = root.number("patch_size");
        scene.refinement = "patch size " + format_number(size) + " (the scene's)";
        if (limits.on_step) limits.on_step("refining");
        refine_within(scene, size, shown, budget, limits.threads, finish);
    } else {
        const auto& pos = scene.vertex_positions();
        Vec3 lo = pos.front(), hi = lo;
        for (const auto& v : pos) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
        const double extent = (hi - lo).maxCoeff();
        size = extent / 25.0;
        scene.refinement = "patch size " + format_number(size) + " (automatic: 1/25 of the scene's largest extent, " +
                           format_number(extent) + "; \"patch_size\" sets it, \"none\" keeps the patches as modelled)";
        if (limits.on_step) limits.on_step("refining");
        try {
            refine_within(scene, size, shown, budget, limits.threads, finish);
        } catch (const SceneError& e) {
            const std::string what = e.what(), key = "patch_size: ";
            const auto at = what.find(key);
            throw SceneError(shown, "patch_size", "the automatic size (1/25 of the largest extent) " +
                                                      what.substr(at == std::string::npos ? 0 : at + key.size()) +
                                                      ": set \"patch_size\" to a larger number or \"none\"");
        }
    }
}

}  // namespace

namespace {

Scene parse_document(const std::string& text, const std::string& shown, const std::string& base_dir,
                     const Overrides& overrides, const LoadLimits& limits) {
    json doc;
    // A byte offset (from 1) as "file:line:column".
    const auto at_byte = [&](std::size_t byte) {
        std::size_t line = 1, col = 1;
        for (std::size_t i = 0; i + 1 < byte && i < text.size(); ++i) {
            if (text[i] == '\n') {
                ++line;
                col = 1;
            } else {
                ++col;
            }
        }
        return shown + ":" + std::to_string(line) + ":" + std::to_string(col);
    };
    try {
        doc = parse_json(text, shown);
    } catch (const json::parse_error& e) {
        std::string msg = e.what();
        const auto colon = msg.find(": ", msg.find("parse error"));
        if (colon != std::string::npos) msg = msg.substr(colon + 2);
        throw SceneError(at_byte(e.byte), "", "malformed JSON: " + cut(msg, 200));
    } catch (const json::exception& e) {
        // Not a syntax error but a value JSON cannot hold (e.g. 1e999 overflows a
        // double): the parser gives no place, so the number's first appearance is named.
        std::string msg = e.what();
        const auto bracket = msg.find("] ");
        if (bracket != std::string::npos) msg = msg.substr(bracket + 2);
        std::string where = shown;
        const auto open = msg.find('\''), close = msg.rfind('\'');
        if (open != std::string::npos && close > open + 1) {
            const std::string number = msg.substr(open + 1, close - open - 1);
            // Its first appearance as a whole word outside strings ("name": "1e999").
            bool in_string = false;
            std::size_t scanned = 0;
            for (std::size_t i = text.find(number); i != std::string::npos; i = text.find(number, i + 1)) {
                for (; scanned < i; ++scanned)
                    if (text[scanned] == '\\' && in_string) ++scanned;
                    else if (text[scanned] == '"') in_string = !in_string;
                if (in_string) continue;
                const auto part_of_word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '.'; };
                const std::size_t end = i + number.size();
                if ((i == 0 || !part_of_word(text[i - 1])) && (end >= text.size() || !part_of_word(text[end]))) {
                    where = at_byte(i + 1);
                    break;
                }
            }
        }
        throw SceneError(where, "", "invalid number: " + cut(msg, 200) + " (not finite)");
    }

    if (limits.on_step) limits.on_step("reading");
    const json materials_before = doc.is_object() && doc.contains("materials") ? doc["materials"] : json();
    // -D materials.X.albedo[0]=v where the file defines no X: an element of values a mesh
    // brings, which the document does not hold. Kept (its key below the material) and
    // applied to the brought values (apply_edits).
    std::map<std::string, Overrides> element_edits;
    const auto element_edit = [&](const Override& o) {
        std::string name, rest;
        if (o.key.rfind("materials.", 0) == 0) {
            const std::size_t end = o.key.find_first_of(".[", 10);
            if (end == std::string::npos) return false;
            name = o.key.substr(10, end - 10), rest = o.key.substr(o.key[end] == '.' ? end + 1 : end);
        } else if (o.key.rfind("materials[\"", 0) == 0) {
            const std::size_t close = o.key.find("\"]", 11);
            if (close == std::string::npos) return false;
            name = o.key.substr(11, close - 11), rest = o.key.substr(close + 2);
            if (!rest.empty() && rest[0] == '.') rest.erase(0, 1);
        } else {
            return false;
        }
        // (materials.X[0]: X is no array; left to the document, which says so)
        if (name.empty() || rest.empty() || rest[0] == '[' || rest.find('[') == std::string::npos) return false;
        if (materials_before.is_object() && materials_before.contains(name)) return false;
        if (std::any_of(overrides.begin(), overrides.end(), [&](const Override& w) {
                return w.key == "materials." + name || w.key == "materials[\"" + name + "\"]";
            }))
            return false;  // the whole material given: its elements are in the document
        element_edits[name].push_back({rest, o.value, o.given.empty() ? "-D " + o.key + "=" + o.value : o.given});
        return true;
    };
    // The image's sides last: the other side follows the camera as the rest made it.
    for (const Override& o : overrides)
        if (!image_side(o) && !element_edit(o)) apply_override(doc, o, shown);
    const json camera_before = doc.is_object() && doc.contains("camera") && doc["camera"].is_object() ? doc["camera"] : json();
    for (const Override& o : overrides)
        if (image_side(o)) apply_override(doc, o, shown);
    if (doc.is_object() && doc.contains("camera") && doc["camera"].is_object() &&
        (doc["camera"].contains("eye") || doc["camera"].contains("target")))
        follow_aspect(doc["camera"], camera_before, overrides, shown);  // a camera of its own
    Node root(doc, shown, "");
    root.require_object();
    root.check_keys(
        {"camera", "crease_angle", "cut_contacts", "directional_lights", "materials", "objects", "patch_size",
         "point_lights", "sky"});
    const double crease = root.has("crease_angle") ? crease_angle(root) : Scene::default_crease_angle;

    Scene scene;
    scene.name = shown;
    // Without its own camera (no camera, or one that places no eye and no target: -D
    // camera.width=800 alone), the scene takes the first a glTF mesh brings, with the
    // values it does give laid over it.
    const json* given_camera = doc.is_object() && doc.contains("camera") ? &doc["camera"] : nullptr;
    const bool own_camera = given_camera && (!given_camera->is_object() || given_camera->contains("eye") ||
                                             given_camera->contains("target"));
    if (own_camera) scene.camera = parse_camera(root.child("camera"));
    std::optional<Camera> brought;

    // Materials: the scene's, then those its meshes bring (mesh_materials); a scene of
    // such meshes alone needs none of its own. Some values of a material the file does
    // not define, given by -D (-D materials.lamp.emission=[9, 9, 9], not the whole
    // material), edit each material of that name a mesh brings: its own values with
    // those laid over them, before it is shared or renamed. Where no mesh brings one,
    // they are a new material, which needs its albedo.
    std::map<std::string, json> edits;  // name: the values -D gives it
    std::set<std::string> taken;        // the edits a mesh's material took, or made anew
    const auto given_whole = [&overrides](const std::string& name) {
        return std::any_of(overrides.begin(), overrides.end(), [&](const Override& o) {
            return o.key == "materials." + name || o.key == "materials[\"" + name + "\"]";
        });
    };
    if (root.has("materials")) {
        const Node mats = root.child("materials");
        mats.require_object();
        for (auto it = doc["materials"].begin(); it != doc["materials"].end(); ++it) {
            const bool the_files = materials_before.is_object() && materials_before.contains(it.key());
            if (!the_files && !given_whole(it.key()) && it.value().is_object()) {
                edits[it.key()] = it.value();  // for the meshes' materials, an object's, or new at the end
                continue;
            }
            scene.add_material(parse_material(Node(it.value(), shown, "materials." + it.key()), it.key()));
        }
    }
    for (const auto& [name, list] : element_edits)
        if (!edits.count(name)) edits[name] = json::object();
    // An edit as a material of its own (an object names it before a mesh brings it, or
    // none does), which needs its albedo.
    const auto new_material = [&](const std::string& name, const std::string& why) {
        json values = edits.at(name);
        if (const auto elements = element_edits.find(name); elements != element_edits.end())
            for (const Override& o : elements->second) apply_override(values, o, shown);
        if (!values.contains("albedo"))
            throw SceneError(shown, material_setting(name),
                             "no material '" + name + "' for -D to change a value of: " + why +
                                 " (a new material needs its albedo)");
        taken.insert(name);
        return scene.add_material(parse_material(Node(values, shown, material_setting(name)), name));
    };
    const std::size_t scene_materials = scene.materials.size();  // the file's own: they replace the meshes'
    // A brought material with the values -D gives it (its lobe's exponent only where it
    // has a lobe: a specular given to a diffuse one needs its exponent too).
    const MaterialEdits apply_edits = [&](Material& m) {
        const auto e = edits.find(m.name);
        if (e == edits.end()) return false;
        const auto rgb = [](const Rgb& c) { return json::array({c[0], c[1], c[2]}); };
        json merged = {{"albedo", rgb(m.albedo)}, {"emission", rgb(m.emission)}, {"two_sided", m.two_sided}};
        if (m.glossy()) merged["specular"] = rgb(m.specular), merged["exponent"] = m.exponent;
        merged.merge_patch(e->second);
        if (const auto elements = element_edits.find(m.name); elements != element_edits.end())
            for (const Override& o : elements->second) {
                try {
                    apply_override(merged, o, shown);
                } catch (const SceneError& error) {
                    const std::string& problem = error.problem();
                    throw SceneError(shown, material_setting(m.name) + "." + o.key,
                                     problem.substr(0, problem.find(" (-D ")) + " in the values the mesh brings (" +
                                         o.given + ")");
                }
            }
        // Whether the settings give this value (whole, or one of its elements).
        const auto touches = [&](const std::string& key) {
            if (e->second.is_object() && e->second.contains(key)) return true;
            const auto elements = element_edits.find(m.name);
            return elements != element_edits.end() &&
                   std::any_of(elements->second.begin(), elements->second.end(),
                               [&](const Override& o) { return o.key.rfind(key + "[", 0) == 0; });
        };
        // The contraction check counts the albedo times the vertex colours' bound (a
        // base colour of 1 that colours below 1 dim reflects less than it receives); the
        // material keeps the albedo as set.
        const Rgb bound = m.colour_bound;
        json checked = merged;
        std::optional<Rgb> albedo;
        if (const json& a = merged["albedo"]; (bound < 1.0).any() && a.is_array() && a.size() == 3 &&
                                               std::all_of(a.begin(), a.end(), [](const json& v) { return v.is_number(); })) {
            albedo = Rgb(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
            checked["albedo"] = rgb(*albedo * bound);
        }
        auto texture = m.texture;
        const Rgb tint = m.tint;
        const Eigen::Matrix2d uv_linear = m.uv_linear;
        const Uv uv_offset = m.uv_offset;
        m = parse_material(Node(checked, shown, material_setting(m.name)), m.name);
        if (albedo) m.albedo = *albedo;
        m.colour_bound = bound;
        // A texture stays unless the settings give the albedo (a colour in its place); its
        // brightest texels with the specular set may reach 1 at most.
        if (texture && !touches("albedo")) {
            const Rgb most = tint * texture->image->brightest * bound + m.specular;
            Eigen::Index k = 0;
            if (!(most.maxCoeff(&k) <= 1.0))
                Node(merged, shown, material_setting(m.name))
                    .fail("", "its texture's brightest texels + specular = " + format_number(most[k]) + " in channel " +
                                  "rgb"[k] + " (must be at most 1 so that the light transport contracts: a specular of " +
                                  "at most " + format_number(1.0 - (tint * texture->image->brightest * bound)[k]) +
                                  " there, or an albedo in the texture's place)");
            m.texture = std::move(texture), m.tint = tint, m.uv_linear = uv_linear, m.uv_offset = uv_offset;
        }
        taken.insert(e->first);
        return true;
    };

    const json& objects = root.raw("objects");
    if (!objects.is_array()) root.fail("objects", std::string("expected an array, got ") + type_name(objects));
    for (std::size_t i = 0; i < objects.size(); ++i) {
        const Node obj(objects[i], shown, "objects[" + std::to_string(i) + "]");
        obj.require_object();
        obj.check_keys({"mesh", "quad", "triangle", "material", "name", "crease_angle", "normals", "scale", "rotate",
                        "translate", "light_scale"});
        const double obj_crease = obj.has("crease_angle") ? crease_angle(obj) : crease;
        // The object's name in warnings and `raybundle check`: its own, or where it is.
        const std::string given = obj.has("name") ? obj.string("name") : "";
        const int kinds = obj.has("mesh") + obj.has("quad") + obj.has("triangle");
        if (kinds != 1) obj.fail("", "needs exactly one of 'mesh', 'quad', 'triangle'");
        // A mesh without "material" brings its own (OBJ usemtl and MTL).
        const bool own_materials = obj.has("mesh") && !obj.has("material");
        int mat = -1;
        if (!own_materials) {
            const std::string mat_name = obj.string("material");
            mat = scene.find_material(mat_name);
            if (mat < 0 && edits.count(mat_name))
                mat = new_material(mat_name, obj.path() + " names it before any mesh brings one");
            if (mat < 0) {
                std::string known;
                for (const auto& m : scene.materials) known += (known.empty() ? "" : ", ") + m.name;
                obj.fail("material", "unknown material '" + mat_name + "' (known: " +
                                         (known.empty() ? "none" : known) + ")");
            }
        }
        if (obj.has("mesh")) {
            const std::string rel = obj.string("mesh");
            const std::string full = (!rel.empty() && rel[0] == '/') ? rel : base_dir + "/" + rel;
            MeshData data;
            scene.files.push_back(full);
            try {
                data = read_mesh_file(full, rel);
            } catch (const SceneError& e) {
                obj.fail("mesh", e.what());
            }
            if (obj.has("scale") || obj.has("rotate") || obj.has("translate")) place_mesh(obj, data);
            if (!brought && data.camera) brought = data.camera;
            // What a glTF file brings besides its triangles.
            scene.files.insert(scene.files.end(), data.resources.begin(), data.resources.end());
            scene.warnings.insert(scene.warnings.end(), data.warnings.begin(), data.warnings.end());
            if (obj.has("light_scale")) {
                const double factor = obj.number("light_scale");
                if (!(factor >= 0.0)) obj.fail("light_scale", "must be 0 or more, got " + format_number(factor));
                for (auto& light : data.point_lights) light.intensity *= factor;
                for (auto& light : data.directional_lights) light.irradiance *= factor;
            } else if (data.blender_lights) {
                scene.warnings.push_back(
                    rel + ": written by Blender, whose default lighting export (\"Standard\") writes its lights 683 "
                          "times the scale of its emission (as lux and candela); read as written. -D " +
                    obj.path() + ".light_scale=0.001464 (1/683) reads them as Blender's importer does");
            }
            for (std::size_t k = 0; k < data.point_lights.size(); ++k) {
                const double most = data.point_lights[k].intensity.maxCoeff();
                if (!(most <= kMaxMagnitude))  // as a scene file's point light
                    obj.fail("mesh", rel + ": point light " + std::to_string(k) + ": intensity " + format_number(most) +
                                         " is too large (at most " + format_number(kMaxMagnitude) + ")");
            }
            scene.point_lights.insert(scene.point_lights.end(), data.point_lights.begin(), data.point_lights.end());
            for (std::size_t k = 0; k < data.directional_lights.size(); ++k) {
                const double most = data.directional_lights[k].irradiance.maxCoeff();
                if (!(most <= kMaxMagnitude))
                    obj.fail("mesh", rel + ": directional light " + std::to_string(k) + ": irradiance " +
                                         format_number(most) + " is too large (at most " + format_number(kMaxMagnitude) +
                                         ")");
            }
            scene.directional_lights.insert(scene.directional_lights.end(), data.directional_lights.begin(),
                                            data.directional_lights.end());
            for (std::size_t v = 0; v < data.vertices.size(); ++v) {
                if (!data.vertices[v].allFinite())  // a placement's inf - inf
                    obj.fail("mesh", rel + ": vertex " + std::to_string(v) + ": (" + format_number(data.vertices[v].x()) + ", " +
                                         format_number(data.vertices[v].y()) + ", " + format_number(data.vertices[v].z()) +
                                         ") is not finite once placed");
                if (data.vertices[v].cwiseAbs().maxCoeff() > kMaxMagnitude)
                    obj.fail("mesh", rel + ": vertex " + std::to_string(v) + ": coordinate " +
                                         format_number(data.vertices[v].cwiseAbs().maxCoeff()) + " is too large (at most " +
                                         format_number(kMaxMagnitude) + " in magnitude)");
            }
            for (const auto& t : data.triangles)
                for (int k : t)
                    if (k < 0 || k >= static_cast<int>(data.vertices.size()))
                        obj.fail("mesh", "face index " + std::to_string(k) + " out of range");
            scene.welded_vertices += weld(data);
            // The file's normals unless the object asks for computed ones.
            const std::string source = obj.has("normals") ? obj.string("normals") : "auto";
            if (source != "auto" && source != "file" && source != "computed")
                obj.fail("normals", "unknown normals '" + source + "' (known: auto, file, computed)");
            if (source == "file" && data.normals.empty()) obj.fail("normals", "'file', but " + rel + " has no normals");
            if (source == "computed") data.normals.clear();
            if (own_materials) {
                std::vector<int> materials;
                try {
                    materials = mesh_materials(scene, scene_materials, data, full, rel, "", apply_edits);
                } catch (const SceneError& e) {
                    // A -D edit the brought material's values refuse: the setting's error.
                    if (e.file() == shown && e.where().rfind("materials", 0) == 0) throw;
                    obj.fail("mesh", e.what());  // the scene file and object, then the mesh or MTL file
                }
                add_mesh_groups(scene, data, materials, !given.empty() ? given : obj.path() + " (" + rel, !given.empty(),
                                obj_crease);
                continue;
            }
            const std::string object_name = !given.empty() ? given : obj.path() + " (" + rel + ")";
            warn_without_uvs(scene, object_name, mat, data.triangles.size(), data.uvs);
            const int id = scene.add_object(data.vertices, data.triangles, mat, object_name, -1, data.normals, data.uvs,
                                            data.colours);
            // The twin faces the other way: its corners in reverse, its normals negated.
            if (scene.materials[mat].two_sided) {
                auto twin_normals = data.normals;
                for (auto& n : twin_normals) n = {-n[0], -n[2], -n[1]};
                auto twin_uvs = data.uvs;
                for (auto& c : twin_uvs) std::swap(c[1], c[2]);
                auto twin_colours = data.colours;
                for (auto& c : twin_colours) std::swap(c[1], c[2]);
                scene.add_object(data.vertices, reversed(data.triangles), mat, "", id, twin_normals, twin_uvs,
                                 twin_colours);
            }
            scene.crease_angles[id] = obj_crease;
        } else {
            if (obj.has("normals")) obj.fail("normals", "only a mesh object has a choice of normals");
            if (obj.has("light_scale")) obj.fail("light_scale", "scales the lights a mesh file brings (a glTF's) only");
            for (const char* placement : {"scale", "rotate", "translate"})
                if (obj.has(placement))
                    obj.fail(placement, "places a mesh object only (a quad's or triangle's corners are its place)");
            const bool quad = obj.has("quad");
            const char* key = quad ? "quad" : "triangle";
            const json& pts = obj.raw(key);
            const std::size_t want = quad ? 4 : 3;
            if (!pts.is_array() || pts.size() != want)
                obj.fail(key, "expected " + std::to_string(want) + " points [x, y, z], got " + shown_value(pts));
            std::vector<Vec3> v;
            for (std::size_t k = 0; k < want; ++k)
                v.push_back(obj.vec3(pts[k], obj.at(key) + "[" + std::to_string(k) + "]"));
            // A quad is one flat surface of four corners: corners that coincide or three
            // on one line (a triangle or a line), a bend (past 1e-6 of its size: hand-typed
            // coordinates are flat to rounding) or a crossing are mistakes, not surfaces.
            std::vector<std::array<int, 3>> tris = {{0, 1, 2}};
            if (quad) {
                double size = 0.0;
                for (const auto& a : v)
                    for (const auto& b : v) size = std::max(size, (a - b).norm());
                for (std::size_t k = 0; k < 4; ++k) {
                    const Vec3 &a = v[(k + 3) % 4], &b = v[k], &c = v[(k + 1) % 4];
                    if (!((b - a).norm() > 1e-9 * size) || !((c - b).cross(a - b).norm() > 1e-9 * size * size))
                        obj.fail(key, "is degenerate: its points " + std::to_string((k + 3) % 4) + ", " +
                                          std::to_string(k) + ", " + std::to_string((k + 1) % 4) +
                                          " coincide or lie on one line (a triangle is a \"triangle\")");
                }
                tris = triangulate_polygon(v, 1e-6, shown, obj.at(key));
            } else {
                // A triangle typed by hand with corners that coincide or lie on a line is a
                // mistake too (a mesh's such faces are dropped with a warning instead).
                const double size = std::max({(v[1] - v[0]).norm(), (v[2] - v[1]).norm(), (v[0] - v[2]).norm()});
                if (!((v[1] - v[0]).cross(v[2] - v[0]).norm() > 1e-9 * size * size))
                    obj.fail(key, "is degenerate: its points coincide or lie on one line");
            }
            const std::string object_name = !given.empty() ? given : obj.path() + " (" + key + ")";
            warn_without_uvs(scene, object_name, mat, tris.size(), {});
            const int id = scene.add_object(v, tris, mat, object_name);
            if (scene.materials[mat].two_sided) scene.add_object(v, reversed(tris), mat, "", id);
            scene.crease_angles[id] = obj_crease;
        }
    }

    if (!own_camera) {
        if (!brought) {
            if (given_camera) parse_camera(root.child("camera"));  // names what it lacks: camera.eye
            root.fail("camera", "missing (and no glTF mesh of the scene brings one)");
        }
        json merged = camera_json(*brought);
        json was = merged;  // the brought camera's sides, where the file set none
        if (camera_before.is_object())
            for (const char* key : {"width", "height"})
                if (camera_before.contains(key)) was[key] = camera_before[key];
        if (given_camera)
            for (auto it = given_camera->begin(); it != given_camera->end(); ++it) merged[it.key()] = it.value();
        follow_aspect(merged, was, overrides, shown);
        scene.camera = parse_camera(Node(merged, shown, "camera"));
    }

    // Each element of the array at `key` (if given), as a node named "key[i]".
    const auto each_element = [&](const char* key, auto&& take) {
        if (!root.has(key)) return;
        const json& list = root.raw(key);
        if (!list.is_array()) root.fail(key, std::string("expected an array, got ") + type_name(list));
        for (std::size_t i = 0; i < list.size(); ++i)
            take(Node(list[i], shown, std::string(key) + "[" + std::to_string(i) + "]"));
    };
    each_element("point_lights", [&](const Node& n) { scene.point_lights.push_back(parse_point_light(n)); });
    each_element("directional_lights",
                 [&](const Node& n) { scene.directional_lights.push_back(parse_directional_light(n)); });
    if (root.has("sky")) scene.sky = parse_sky(root.child("sky"));
    for (const auto& [name, values] : edits)
        if (!taken.count(name)) new_material(name, "the scene's own materials and its meshes' have none of that name");

    if (scene.mesh.n_faces() == 0) throw SceneError(shown, "objects", "the scene has no patches");
    if (limits.on_step) limits.on_step("normals");
    scene.finalize(limits.threads);
    // A material kept at an albedo of 1 because vertex colours dim it (colour_bound) on
    // a patch without colours would reflect all it receives.
    if (std::any_of(scene.materials.begin(), scene.materials.end(), [](const Material& m) { return (m.colour_bound < 1.0).any(); }))
        for (std::size_t i = 0; i < scene.patch_count(); ++i) {
            const Material& m = scene.material_of(i);
            Eigen::Index k = 0;
            const double most = (scene.albedo_of(i) + m.specular).maxCoeff(&k);
            if (most < 1.0) continue;
            throw SceneError(shown, material_setting(m.name),
                             "albedo + specular = " + format_number(most) + " in channel " + "rgb"[k] + " on " +
                                 scene.object_names[static_cast<std::size_t>(scene.patch_list()[i].object)] +
                                 ", which has no vertex colours to dim it (the mesh that brings it has them): give that "
                                 "object a material of its own, or -D " + material_setting(m.name) + ".albedo=[r, g, b]");
        }
    const bool cuts = !root.has("cut_contacts") || root.boolean("cut_contacts");
    refine(scene, root, shown, limits, cuts ? Finish::leave_mesh : Finish::finalize);  // the cuts finalize
    if (cuts) {
        if (limits.on_step) limits.on_step("contacts");
        cut_at_contacts(scene, limits.threads, limits.team);
    } else {
        skip_contact_search(scene, limits.team);
    }
    return scene;
}

// How a -D setting `key` bears on error e: 2 where e is at the setting's path or inside
// it, at the array the setting is an element of, or at a parent of it and names the
// setting's own key (an unknown key); 1 where e is at a parent of it (a check of the
// values together, e.g. albedo + specular); else 0.
int bearing(const std::string& key, const SceneError& e) {
    const std::string& where = e.where();
    const auto below = [](const std::string& path, const std::string& top) {
        return top.empty() || (path.size() > top.size() && path.compare(0, top.size(), top) == 0 &&
                               (path[top.size()] == '.' || path[top.size()] == '['));
    };
    if (where == key || (!where.empty() && below(where, key))) return 2;
    if (!below(key, where)) return 0;  // elsewhere in the document
    if (!where.empty() && key[where.size()] == '[') return 2;  // an element of the value at fault
    const std::size_t from = where.empty() ? 0 : where.size() + 1;
    const std::string part = key.substr(from, key.find_first_of(".[", from) - from);
    if (!part.empty() && e.problem().find("'" + part + "'") != std::string::npos) return 2;
    return where.empty() ? 0 : 1;
}

// Runs `body`; an error in the scene `shown` that a setting caused names it (the last
// that did: the last given wins), which the file does not hold; one that settings may
// have caused (a check of values together) lists them.
template <class Body>
Scene naming_overrides(const Overrides& overrides, const std::string& shown, Body body) {
    try {
        return body();
    } catch (const SceneError& e) {
        if (e.file() != shown || e.problem().find("-D ") != std::string::npos) throw;
        const auto given = [](const Override& o) { return o.given.empty() ? "-D " + o.key + "=" + o.value : o.given; };
        for (auto o = overrides.rbegin(); o != overrides.rend(); ++o)
            if (bearing(o->key, e) == 2) throw SceneError(e.file(), e.where(), e.problem() + " (from " + given(*o) + ")");
        std::string with;
        for (const Override& o : overrides)
            if (bearing(o.key, e) == 1) with += (with.empty() ? "" : ", ") + given(o);
        if (!with.empty()) throw SceneError(e.file(), e.where(), e.problem() + " (with " + with + ")");
        throw;
    }
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& shown, const std::string& base_dir,
                  const Overrides& overrides, const LoadLimits& limits) {
    return naming_overrides(overrides, shown, [&] { return parse_document(text, shown, base_dir, overrides, limits); });
}

namespace {

// The extension of a path, lower case ("obj"), or "".
std::string extension_of(const std::string& path) {
    const auto slash = path.find_last_of('/'), dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot + 1);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// A model file alone as a scene: the document parse_scene would read, with the file's
// camera (glTF) or one that frames it from +z, and the automatic patch size.
Scene load_model(const std::string& path, const Overrides& overrides, const LoadLimits& limits) {
    if (limits.on_step) limits.on_step("reading");
    const MeshData data = read_mesh_file(path, path);
    if (data.vertices.empty()) throw SceneError(path, "", "has no vertices");
    // The bounds of its faces: a loose vertex or a wire edge's (Blender writes them) is
    // not in view.
    Vec3 lo = data.vertices.front(), hi = lo;
    if (!data.triangles.empty()) lo = hi = data.vertices[static_cast<std::size_t>(data.triangles.front()[0])];
    for (const auto& t : data.triangles)
        for (const int k : t) lo = lo.cwiseMin(data.vertices[static_cast<std::size_t>(k)]), hi = hi.cwiseMax(data.vertices[static_cast<std::size_t>(k)]);
    if (data.triangles.empty())
        for (const auto& v : data.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    const Vec3 centre = 0.5 * (lo + hi), extent = hi - lo;
    const double size = extent.maxCoeff(), fov = 40.0;
    const double distance = 0.5 * std::max({extent.x(), extent.y(), 1e-9 * size}) / std::tan(0.5 * fov * M_PI / 180.0);
    const std::string name = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
    json camera = {{"eye", {centre.x(), centre.y(), hi.z() + distance}},
                   {"target", {centre.x(), centre.y(), centre.z()}},
                   {"fov_y", fov}};
    // A flat horizontal model (a ground alone; Blender's plane, glTF's +y up) would be
    // seen edge-on from +z: from 45 degrees above the side its faces mostly face.
    if (!data.triangles.empty() && extent.y() <= 1e-6 * size) {
        double facing_up = 0.0;  // the area-weighted y of its faces' normals (sign)
        for (const auto& t : data.triangles) {
            const Vec3& a = data.vertices[static_cast<std::size_t>(t[0])];
            facing_up += (data.vertices[static_cast<std::size_t>(t[1])] - a)
                             .cross(data.vertices[static_cast<std::size_t>(t[2])] - a)
                             .y();
        }
        const double side = facing_up < 0.0 ? -1.0 : 1.0, away = 0.6 * size / std::tan(0.5 * fov * M_PI / 180.0);
        camera["eye"] = {centre.x(), centre.y() + side * away * M_SQRT1_2, centre.z() + away * M_SQRT1_2};
    }
    if (data.camera) {
        camera = camera_json(*data.camera);
        // The node's up belongs to its own view, rolled with it. Moved by -D (another eye
        // or target, no up), the camera stands level, +y up, as a scene file's camera
        // without "up": else a tilted node's up would roll the new view.
        const auto given = [&](const std::string& key) {
            return std::any_of(overrides.begin(), overrides.end(), [&](const Override& o) {
                return o.key == key || o.key.rfind(key + "[", 0) == 0;
            });
        };
        if ((given("camera.eye") || given("camera.target")) && !given("camera.up")) {
            // (unless the new view runs along y, where +y cannot be up: the node's up stays)
            json probe = {{"camera", camera}};
            bool along_y = false;
            try {
                for (const Override& o : overrides)
                    if (o.key.rfind("camera.", 0) == 0) apply_override(probe, o, path);
                const auto point = [](const json& v) {
                    return v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number()
                               ? Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>())
                               : Vec3::Zero();
                };
                const Vec3 view = point(probe["camera"]["target"]) - point(probe["camera"]["eye"]);
                along_y = view.norm() > 0.0 && Vec3::UnitY().cross(view).norm() <= 1e-9 * view.norm();
            } catch (const SceneError&) {
                // (the document's own parse says what is wrong)
            }
            if (!along_y) camera.erase("up");
        }
    }
    // Its parts named "room.obj: Floor", as in a scene file's object named "room.obj".
    const json doc = {{"camera", camera}, {"objects", json::array({{{"mesh", name}, {"name", name}}})}};
    Scene scene = [&] {  // made in place: a Scene copied costs milliseconds
        try {
            return parse_scene(doc.dump(), path, dir_of(path), overrides, limits);
        } catch (const SceneError& e) {
            // The model's own error ("room.obj: line 7: ..."), not that of a scene file's
            // objects[0].mesh, which the user never wrote; the file as the user named it.
            // The camera placed to frame it, past the coordinates' bound: the model's
            // size and place are the reason, not a camera the user never set.
            const bool eye_given = std::any_of(overrides.begin(), overrides.end(), [](const Override& o) {
                return o.key == "camera" || o.key == "camera.eye" || o.key.rfind("camera.eye[", 0) == 0;
            });
            if (e.where() == "camera.eye" && !data.camera && !eye_given && e.problem().find("too large") != std::string::npos)
                throw SceneError(path, "", "the camera placed to frame it (" + format_number(distance) +
                                               " from its centre) would lie past 1e15 from the origin: give camera.eye "
                                               "(-D camera.eye=[x, y, z]) or a model nearer the origin, of a size "
                                               "below 1e15");
            if (e.where() != "objects[0].mesh") throw;
            const std::string& problem = e.problem();
            throw SceneError(path, "", problem.rfind(name + ": ", 0) == 0 ? problem.substr(name.size() + 2) : problem);
        }
    }();
    scene.files.insert(scene.files.begin(), path);
    return scene;
}

}  // namespace

Scene load_scene(const std::string& path, const Overrides& overrides, int threads, const PreparationTeam* team) {
    LoadLimits limits;
    limits.threads = threads;
    limits.team = team;
    return load_scene(path, overrides, limits);
}

Scene load_scene(const std::string& path, const Overrides& overrides, const LoadLimits& limits) {
    const std::string ext = extension_of(path);
    if (ext == "obj" || ext == "gltf" || ext == "glb") return load_model(path, overrides, limits);
    std::error_code ec;
    if ((ext == "ply" || ext == "off") && std::filesystem::is_regular_file(path, ec))
        throw SceneError(path, "", "a " + ext + " file has no materials: name it in a scene file (docs/scene-format.md)");
    Scene scene =
        parse_scene(read_input_file(path, path, "scene file", kMaxSceneFileBytes), path, dir_of(path), overrides, limits);
    scene.files.insert(scene.files.begin(), path);
    return scene;
}

namespace {

Scene builtin_with(const std::string& name, const Overrides& overrides, int threads, const PreparationTeam* team,
                   const MemoryShare& memory) {
    std::optional<double> default_size;
    for (const auto& info : builtin_scenes())
        if (info.name == name) default_size = info.default_patch_size;
    if (!default_size) make_builtin(name);  // throws: unknown, listing the known ones
    // The overridable settings as documents, checked like a file's: the patch size
    // first (it makes the scene), then the camera. One scene returned by name: a Scene
    // moved is a Scene copied (OpenMesh's kernel has no move), 3 ms at 121k patches.
    json sizes = {{"patch_size", *default_size}}, camera = json::object();
    bool sized = false;
    for (const Override& o : overrides) {
        const std::string root_key = o.key.substr(0, o.key.find_first_of(".["));
        if (root_key != "camera" && root_key != "patch_size")
            throw SceneError(name, o.key, "a built-in scene takes overrides of camera.* and patch_size only");
        if (root_key == "patch_size") apply_override(sizes, o, name), sized = true;
    }
    const std::optional<double> size =
        sized ? std::optional<double>(Node(sizes, name, "").number("patch_size")) : std::nullopt;
    Scene scene = make_builtin(name, size, threads, team, memory);
    if (!overrides.empty()) {
        camera["camera"] = camera_json(scene.camera);
        for (const Override& o : overrides)
            if (o.key.rfind("camera", 0) == 0 && !image_side(o)) apply_override(camera, o, name);
        const json before = camera["camera"];
        for (const Override& o : overrides)
            if (image_side(o)) apply_override(camera, o, name);
        follow_aspect(camera["camera"], before, overrides, name);
        scene.camera = parse_camera(Node(camera, name, "").child("camera"));
    }
    return scene;
}

}  // namespace

Scene load_builtin(const std::string& name, const Overrides& overrides, int threads, const PreparationTeam* team,
                   const MemoryShare& memory) {
    return naming_overrides(overrides, name, [&] { return builtin_with(name, overrides, threads, team, memory); });
}

}  // namespace raybundle::scenes
