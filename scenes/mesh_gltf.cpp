// glTF 2.0 (.gltf and .glb) through tinygltf (scenes/tiny_gltf.cpp): the triangles of
// the default scene's nodes in world space, with their materials mapped to ours, the
// KHR_lights_punctual point, spot and directional lights and the first camera
// (docs/scene-format.md, "glTF").
// tinygltf parses the JSON and the GLB container and decodes data URIs; everything it
// leaves unchecked (accessor ranges, indices, the node tree) is checked here, before
// anything is allocated for it.
#include "scenes/errors.h"
#include "scenes/mesh_readers.h"

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <unordered_map>

namespace raybundle::scenes::mesh_detail {

namespace {

constexpr std::size_t kMaxJsonNesting = 64;
// The most primitives the node tree may place (a forest of instances has a few million).
constexpr std::size_t kMaxPlacements = 10'000'000;

std::string number(double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", x);
    return text;
}

// nlohmann's parser recurses once per level: a file nested thousands deep would
// overflow the stack inside tinygltf. Counted here first (strings skipped).
void check_nesting(std::string_view json, const std::string& shown) {
    std::size_t depth = 0;
    bool in_string = false, escaped = false;
    for (const char c : json) {
        if (in_string) {
            if (escaped) escaped = false;
            else if (c == '\\') escaped = true;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '{' || c == '[') {
            if (++depth > kMaxJsonNesting)
                throw SceneError(shown, "", "JSON nested more than " + std::to_string(kMaxJsonNesting) + " deep");
        } else if ((c == '}' || c == ']') && depth > 0) {
            --depth;
        }
    }
}

// The GLB container, checked before tinygltf reads it (2.7.0 lets a BIN chunk's length
// reach 8 bytes past the data); returns the JSON chunk, for check_nesting.
std::string_view glb_json(std::string_view bytes, const std::string& shown) {
    const auto word = [&](std::size_t at) {
        std::uint32_t w = 0;
        std::memcpy(&w, bytes.data() + at, 4);
        return std::size_t{w};
    };
    if (bytes.size() < 20 || word(0) != 0x46546C67u) throw SceneError(shown, "", "not a GLB file (no glTF header)");
    if (word(4) != 2) throw SceneError(shown, "", "GLB version " + std::to_string(word(4)) + " (2 is read)");
    const std::size_t length = word(8), json = word(12);
    if (length > bytes.size()) throw SceneError(shown, "", "GLB header says " + std::to_string(length) +
                                                                " bytes, the file has " + std::to_string(bytes.size()));
    if (word(16) != 0x4E4F534Au || json > length - 20)
        throw SceneError(shown, "", "the GLB's first chunk is not JSON within the file");
    if (const std::size_t bin_at = 20 + json; bin_at + 8 <= length) {
        if (word(bin_at) > length - bin_at - 8)
            throw SceneError(shown, "", "the GLB's binary chunk of " + std::to_string(word(bin_at)) +
                                            " bytes runs past the end of the file");
    }
    return bytes.substr(20, json);
}

// File access for tinygltf: regular files in the asset's folder or below it only,
// through read_input_file (no FIFO, device or directory; at most 2 GiB each, 4 GiB in
// all), recorded as inputs.
struct Files {
    std::optional<std::string> folder;
    std::vector<std::string> read;
    std::uintmax_t bytes = 0;
};

bool inside_folder(const Files& files, const std::string& path) {
    if (!files.folder) return false;
    std::error_code ec;
    const auto folder = std::filesystem::weakly_canonical(*files.folder, ec);
    const auto file = std::filesystem::weakly_canonical(path, ec);
    if (ec) return false;
    const auto rel = file.lexically_relative(folder);
    return !rel.empty() && *rel.begin() != "..";
}
bool file_exists(const std::string& path, void* user) {
    std::error_code ec;
    return inside_folder(*static_cast<Files*>(user), path) && std::filesystem::is_regular_file(path, ec);
}
std::string expand_path(const std::string& path, void*) { return path; }  // no wordexp
bool read_file(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
    auto& files = *static_cast<Files*>(user);
    if (!files.folder) {
        *err += "'" + path + "' is another file, and this glTF was read from memory";
        return false;
    }
    if (!inside_folder(files, path)) {
        *err += "'" + path + "' lies outside the asset's folder";
        return false;
    }
    try {
        const std::string bytes = read_input_file(path, path, "glTF resource", kMaxGltfFileBytes);
        files.bytes += bytes.size();
        if (files.bytes > 2 * kMaxGltfFileBytes) {
            *err += "its buffers and images exceed 4 GiB";
            return false;
        }
        out->assign(bytes.begin(), bytes.end());
        files.read.push_back(path);
        return true;
    } catch (const SceneError& e) {
        *err += e.what();
        return false;
    }
}
bool write_file(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
    *err += "the reader writes nothing";
    return false;
}
// Images keep their encoded bytes (a texture is read by its mean colour, PNG only):
// those of a data URI or a file. An image in a buffer view is left there, for the
// reader's checked buffer_view() (tinygltf passes its bytes unchecked).
bool keep_image(tinygltf::Image* image, int, std::string*, std::string*, int, int, const unsigned char* bytes,
                int size, void*) {
    if (image->bufferView < 0 && size > 0) image->image.assign(bytes, bytes + size);
    image->width = image->height = 0;
    return true;
}

// Keys glTF 2.0 does not define in the objects whose keys decide what is placed and
// how it looks (nodes, meshes, primitives, materials): glTF lets a file carry them, and
// tinygltf reads past them, so a typo ("translaton") would move nothing, silently. One
// warning each, with the nearest known key.
std::vector<std::string> unknown_keys(const nlohmann::json& doc, const std::string& shown) {
    std::vector<std::string> out;
    std::size_t unknown = 0;  // the first 20 named, the others counted
    if (!doc.is_object()) return out;  // tinygltf says what is wrong with it
    const auto check = [&](const nlohmann::json& object, const std::string& where,
                           std::initializer_list<const char*> known) {
        if (!object.is_object()) return;
        for (auto it = object.begin(); it != object.end(); ++it) {
            std::string nearest;
            std::size_t best = 3;
            bool found = false;
            for (const char* k : known) {
                if (it.key() == k) found = true;
                // Within 2 edits, or a name it begins ("roughness": roughnessFactor).
                const bool begins = it.key().size() >= 4 && std::string(k).rfind(it.key(), 0) == 0;
                if (const std::size_t d = begins ? 1 : edit_distance(it.key(), k); d < best) best = d, nearest = k;
            }
            if (found) continue;
            if (++unknown > 20) continue;
            out.push_back(shown + ": " + where + ": unknown key '" + it.key() + "' is not read" +
                          (nearest.empty() ? std::string() : " (did you mean '" + nearest + "'?)"));
        }
    };
    const auto each = [&](const char* array, auto&& visit) {
        const auto it = doc.find(array);
        if (it == doc.end() || !it->is_array()) return;
        for (std::size_t i = 0; i < it->size(); ++i)
            visit((*it)[i], std::string(array) + "[" + std::to_string(i) + "]");
    };
    each("nodes", [&](const nlohmann::json& n, const std::string& at) {
        check(n, at, {"camera", "children", "skin", "matrix", "mesh", "rotation", "scale", "translation", "weights",
                      "name", "extensions", "extras"});
    });
    each("meshes", [&](const nlohmann::json& m, const std::string& at) {
        check(m, at, {"primitives", "weights", "name", "extensions", "extras"});
        if (const auto p = m.find("primitives"); m.is_object() && p != m.end() && p->is_array())
            for (std::size_t i = 0; i < p->size(); ++i)
                check((*p)[i], at + ".primitives[" + std::to_string(i) + "]",
                      {"attributes", "indices", "material", "mode", "targets", "extensions", "extras"});
    });
    each("materials", [&](const nlohmann::json& m, const std::string& at) {
        check(m, at, {"name", "extensions", "extras", "pbrMetallicRoughness", "normalTexture", "occlusionTexture",
                      "emissiveTexture", "emissiveFactor", "alphaMode", "alphaCutoff", "doubleSided"});
        if (const auto p = m.find("pbrMetallicRoughness"); m.is_object() && p != m.end())
            check(*p, at + ".pbrMetallicRoughness",
                  {"baseColorFactor", "baseColorTexture", "metallicFactor", "roughnessFactor",
                   "metallicRoughnessTexture", "extensions", "extras"});
    });
    if (const auto ext = doc.find("extensions"); ext != doc.end() && ext->is_object())
        if (const auto punctual = ext->find("KHR_lights_punctual"); punctual != ext->end() && punctual->is_object())
            if (const auto lights = punctual->find("lights"); lights != punctual->end() && lights->is_array())
                for (std::size_t i = 0; i < lights->size(); ++i) {
                    const std::string at = "KHR_lights_punctual.lights[" + std::to_string(i) + "]";
                    const auto& light = (*lights)[i];
                    check(light, at, {"type", "color", "intensity", "range", "spot", "name", "extensions", "extras"});
                    if (const auto spot = light.find("spot"); light.is_object() && spot != light.end())
                        check(*spot, at + ".spot", {"innerConeAngle", "outerConeAngle", "extensions", "extras"});
                }
    if (unknown > 20) out.push_back(shown + ": " + std::to_string(unknown - 20) + " more unknown keys are not read");
    return out;
}

// KHR_lights_punctual's lights as glTF defines them: tinygltf takes a value of the wrong
// type for its default (an intensity "2" as 1, a colour "red" as white), silently.
void check_lights(const nlohmann::json& doc, const std::string& shown) {
    if (!doc.is_object()) return;  // tinygltf says what is wrong with it
    const auto ext = doc.find("extensions");
    if (ext == doc.end() || !ext->is_object()) return;
    const auto punctual = ext->find("KHR_lights_punctual");
    if (punctual == ext->end()) return;
    const std::string base = "extensions.KHR_lights_punctual";
    if (!punctual->is_object()) throw SceneError(shown, base, "expected an object, got " + std::string(punctual->type_name()));
    const auto lights = punctual->find("lights");
    if (lights == punctual->end()) return;
    if (!lights->is_array()) throw SceneError(shown, base + ".lights", "expected an array, got " + std::string(lights->type_name()));
    for (std::size_t i = 0; i < lights->size(); ++i) {
        const auto& light = (*lights)[i];
        const std::string at = base + ".lights[" + std::to_string(i) + "]";
        if (!light.is_object()) throw SceneError(shown, at, "expected an object, got " + std::string(light.type_name()));
        const auto numeric = [&](const nlohmann::json& object, const char* key, const std::string& where) {
            if (const auto v = object.find(key); v != object.end() && !v->is_number())
                throw SceneError(shown, where + "." + key, "expected a number, got " + v->dump());
        };
        if (const auto type = light.find("type"); type == light.end() || !type->is_string())
            throw SceneError(shown, at + ".type", type == light.end() ? "missing (point, spot or directional)"
                                                                       : "expected a string, got " + type->dump());
        numeric(light, "intensity", at);
        numeric(light, "range", at);
        if (const auto colour = light.find("color"); colour != light.end()) {
            const bool rgb = colour->is_array() && colour->size() == 3 &&
                             std::all_of(colour->begin(), colour->end(), [](const nlohmann::json& c) { return c.is_number(); });
            if (!rgb) throw SceneError(shown, at + ".color", "expected [r, g, b], got " + colour->dump());
        }
        if (const auto spot = light.find("spot"); spot != light.end()) {
            if (!spot->is_object()) throw SceneError(shown, at + ".spot", "expected an object, got " + spot->dump());
            numeric(*spot, "innerConeAngle", at + ".spot");
            numeric(*spot, "outerConeAngle", at + ".spot");
        }
    }
}

// What tinygltf reads past, checked on the file's JSON first. An index of -1 (glTF's
// ids start at 0) reads there as "none": a node's mesh would vanish, a primitive lose
// its material or indices. A node with a matrix and any of translation, rotation, scale
// (glTF forbids it) would lose the latter.
void check_ids(const nlohmann::json& doc, const std::string& shown) {
    if (!doc.is_object()) return;  // tinygltf says what is wrong with it
    // The keys whose values are ids, or arrays or objects of ids.
    static const std::set<std::string> ids = {"scene", "camera", "skin", "mesh", "indices", "material", "bufferView",
                                              "buffer", "sampler", "source", "index", "light", "skeleton",
                                              "inverseBindMatrices", "node", "input", "output"};
    static const std::set<std::string> id_lists = {"nodes", "children", "joints", "attributes"};
    const auto refuse = [&](const nlohmann::json& v, const std::string& at) {
        if (v.is_number() && v.get<double>() < 0.0)
            throw SceneError(shown, at, v.dump() + " is not an index (glTF's indices start at 0)");
    };
    std::function<void(const nlohmann::json&, const std::string&)> walk = [&](const nlohmann::json& j,
                                                                              const std::string& at) {
        const auto below = [&](const std::string& key) { return at.empty() ? key : at + "." + key; };
        if (j.is_array()) {
            for (std::size_t i = 0; i < j.size(); ++i) walk(j[i], at + "[" + std::to_string(i) + "]");
            return;
        }
        if (!j.is_object()) return;
        for (auto it = j.begin(); it != j.end(); ++it) {
            if (it.key() == "extras") continue;  // the application's own data
            const std::string where = below(it.key());
            if (ids.count(it.key())) refuse(it.value(), where);
            if (id_lists.count(it.key())) {
                if (it.value().is_array())
                    for (std::size_t i = 0; i < it.value().size(); ++i) refuse(it.value()[i], where + "[" + std::to_string(i) + "]");
                if (it.key() == "attributes" && it.value().is_object())
                    for (auto a = it.value().begin(); a != it.value().end(); ++a) refuse(a.value(), where + "." + a.key());
            }
            if (it.key() == "targets" && it.value().is_array())  // morph targets: attribute name -> accessor
                for (std::size_t i = 0; i < it.value().size(); ++i)
                    if (it.value()[i].is_object())
                        for (auto a = it.value()[i].begin(); a != it.value()[i].end(); ++a)
                            refuse(a.value(), where + "[" + std::to_string(i) + "]." + a.key());
            walk(it.value(), where);
        }
    };
    walk(doc, "");
    if (const auto nodes = doc.find("nodes"); nodes != doc.end() && nodes->is_array())
        for (std::size_t i = 0; i < nodes->size(); ++i) {
            const auto& n = (*nodes)[i];
            if (!n.is_object() || !n.contains("matrix")) continue;
            for (const char* trs : {"translation", "rotation", "scale"})
                if (n.contains(trs))
                    throw SceneError(shown, "nodes[" + std::to_string(i) + "]",
                                     std::string("has both a matrix and a ") + trs +
                                         " (glTF places a node by one or the other)");
        }
}

// The buffer files the asset names (buffers[i].uri other than data URIs), checked before
// tinygltf reads them: one missing or outside the asset's folder is named with its
// object (tinygltf says "File not found" of both, and of no object). Images are left to
// tinygltf: one it cannot read is a warning there, and its material keeps its factor.
// A URI as tinygltf's urldecode reads it: '+' and %XX.
std::string uri_decoded(const std::string& uri) {
    const auto digit = [](char c) {
        return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : 0;
    };
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '+') {
            out += ' ';
        } else if (uri[i] == '%' && uri.size() > i + 2) {
            out += static_cast<char>(digit(uri[i + 1]) << 4 | digit(uri[i + 2]));
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

// Why an image file the asset names gave no bytes (tinygltf says only "File not found").
std::string unread_image_why(const Files& files, const std::string& uri) {
    if (uri.rfind("data:", 0) == 0) return "its data URI holds no image";
    if (!files.folder) return "'" + uri + "' is another file, and this glTF was read from memory";
    const std::string path = (std::filesystem::path(*files.folder) / uri_decoded(uri)).string();
    std::error_code ec;
    if (!inside_folder(files, path)) return "'" + uri + "' lies outside the asset's folder (not read)";
    if (!std::filesystem::is_regular_file(path, ec)) return "'" + uri + "': no such file beside the asset";
    return "'" + uri + "' is empty or unreadable";
}

void check_resources(const nlohmann::json& doc, const std::string& shown, const Files& files) {
    if (!files.folder) return;
    if (!doc.is_object()) return;  // tinygltf says what is wrong with it
    for (const char* kind : {"buffers"}) {
        const auto list = doc.find(kind);
        if (list == doc.end() || !list->is_array()) continue;
        for (std::size_t i = 0; i < list->size(); ++i) {
            const auto& item = (*list)[i];
            if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
            const std::string uri = item["uri"].get<std::string>();
            if (uri.rfind("data:", 0) == 0) continue;
            const std::string where = std::string(kind) + "[" + std::to_string(i) + "].uri";
            const std::string path = (std::filesystem::path(*files.folder) / uri_decoded(uri)).string();
            std::error_code ec;
            if (!inside_folder(files, path))
                throw SceneError(shown, where, "'" + uri + "' lies outside the asset's folder (refused)");
            if (!std::filesystem::exists(path, ec))
                throw SceneError(shown, where, "'" + uri + "': no such file beside the asset");
        }
    }
}

// The first line of tinygltf's message, without its trailing newline.
std::string first_line(const std::string& text) {
    std::string line = text.substr(0, text.find('\n'));
    if (line.size() > 160) line = line.substr(0, 160) + "...";
    return line;
}

using Matrix4 = Eigen::Matrix4d;

// A run of elements of an accessor, checked against its buffer view and buffer.
struct Elements {
    const unsigned char* base = nullptr;
    std::size_t stride = 0, count = 0;
    int component = 0, components = 0;
};

class Reader {
public:
    Reader(const tinygltf::Model& model, const std::string& shown, const Files& files, std::size_t max_triangles,
           MeshData& out)
        : model_(model), shown_(shown), files_(files), max_triangles_(max_triangles), out_(out) {}

    void read() {
        check_extensions();
        read_materials();
        place_tree(roots());
        if (out_.triangles.empty()) throw SceneError(shown_, "", "the glTF scene places no triangles");
        out_.blender_lights = model_.asset.generator.find("Blender") != std::string::npos &&
                              (!out_.point_lights.empty() || !out_.directional_lights.empty());
        // Only the materials the placed triangles use, in order of first use.
        std::vector<int> used(out_.materials.size(), -1);
        std::vector<std::string> names;
        std::vector<Material> defs;
        // Per material, the brightest of its triangles' vertex colours, where all have
        // them (1 where one has none): what its albedo is multiplied by at most, which
        // the energy check counts (a base colour factor of 1 times colours below 1, as
        // exporters write COLOR_0, reflects less than it receives).
        std::vector<Rgb> brightest(out_.materials.size(), Rgb::Zero());
        for (std::size_t t = 0; t < out_.triangle_material.size(); ++t) {
            Rgb& most = brightest[static_cast<std::size_t>(out_.triangle_material[t])];
            if (out_.colours.empty() || !out_.colours[t][0].allFinite())
                most = Rgb::Ones();
            else
                for (const Rgb& c : out_.colours[t]) most = most.max(c);
        }
        for (int& m : out_.triangle_material) {
            auto& u = used[static_cast<std::size_t>(m)];
            if (u < 0) {
                u = static_cast<int>(names.size());
                names.push_back(out_.materials[static_cast<std::size_t>(m)]);
                defs.push_back(material_def(m, brightest[static_cast<std::size_t>(m)]));
            }
            m = u;
        }
        out_.materials = std::move(names);
        out_.material_defs = std::move(defs);
    }

private:
    [[noreturn]] void fail(const std::string& where, const std::string& what) const {
        throw SceneError(shown_, where, what);
    }
    void warn(const std::string& what) { out_.warnings.push_back(shown_ + ": " + what); }

    // Extensions: those it reads, those it may ignore with a warning, and required
    // ones it cannot read (compressed or quantized geometry would be misread).
    void check_extensions() {
        // glTF 1.0 files parse as JSON too, and mean other things by their keys.
        const std::string& version = model_.asset.version;
        if (version.rfind("2.", 0) != 0)
            fail("asset.version", "'" + version + "': raybundle reads glTF 2.0 (a 1.0 file would be misread)");
        // A file that needs a later reader than 2.0 says so ("2.1"); "2.0" and earlier
        // (a minimum of 1.0 is below ours) are read.
        const std::string& least = model_.asset.minVersion;
        if (!least.empty()) {
            int major = 0, minor = 0;
            char dot = 0;
            std::istringstream in(least);
            if (!(in >> major >> dot >> minor) || dot != '.')
                fail("asset.minVersion", "'" + least + "' is not a version (major.minor)");
            if (major > 2 || (major == 2 && minor > 0))
                fail("asset.minVersion", "'" + least + "': the file needs a reader of glTF " + least +
                                             ", and raybundle reads glTF 2.0");
        }
        static const std::set<std::string> read = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                                   "KHR_texture_transform"};
        for (const auto& e : model_.extensionsRequired)
            if (!read.count(e)) fail("extensionsRequired", "needs " + e + ", which raybundle does not read");
        for (const auto& e : model_.extensionsUsed)
            if (!read.count(e)) warn("extension " + e + " is not read (ignored)");
    }

    // ------------------------------------------------------------------ materials
    // A texture (its image a PNG or JPEG: embedded, a data URI, or a file beside the
    // asset; each image decoded once), wrapped as its sampler says, or nothing with why
    // in texture_why_.
    std::shared_ptr<const Texture> texture(int index, const std::string& where) {
        if (index < 0) return nullptr;
        if (const auto it = textures_.find(index); it != textures_.end()) return it->second;
        if (static_cast<std::size_t>(index) >= model_.textures.size()) fail(where, "texture index out of range");
        const auto& t = model_.textures[static_cast<std::size_t>(index)];
        const int source = t.source;
        if (source < 0 || static_cast<std::size_t>(source) >= model_.images.size())
            fail(where, "texture " + std::to_string(index) + ": image index out of range");
        auto& image = images_[source];
        if (!image) {
            const auto& im = model_.images[static_cast<std::size_t>(source)];
            std::optional<TexelImage> decoded;
            std::string& why = image_why_[source];
            if (!im.image.empty()) {
                decoded = decode_image(std::string_view(reinterpret_cast<const char*>(im.image.data()), im.image.size()), &why);
            } else if (im.bufferView >= 0) {
                const auto view = buffer_view(im.bufferView, where + ": image");
                decoded = decode_image(std::string_view(reinterpret_cast<const char*>(view.first), view.second), &why);
            } else {
                why = im.uri.empty() ? "its image has no data" : unread_image_why(files_, im.uri);
            }
            if (decoded) image = std::make_shared<const TexelImage>(std::move(*decoded));
        }
        texture_why_[index] = image_why_[source];
        if (!image) return textures_[index] = nullptr;
        auto out = std::make_shared<Texture>();
        const auto& im = model_.images[static_cast<std::size_t>(source)];
        const bool uri = !im.uri.empty() && im.uri.rfind("data:", 0) != 0;
        out->name = shown_ + ": images[" + std::to_string(source) + "]";
        out->shown = out->name + (uri ? " (" + im.uri + ")" : !im.name.empty() ? " '" + im.name + "'" : std::string());
        out->image = image;
        if (t.sampler >= 0) {
            if (static_cast<std::size_t>(t.sampler) >= model_.samplers.size())
                fail(where, "texture " + std::to_string(index) + ": sampler " + std::to_string(t.sampler) + " out of range");
            const auto& sampler = model_.samplers[static_cast<std::size_t>(t.sampler)];
            const auto wrap = [&](int mode, const char* key) {
                if (mode == TINYGLTF_TEXTURE_WRAP_REPEAT) return Texture::Wrap::repeat;
                if (mode == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE) return Texture::Wrap::clamp;
                if (mode == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT) return Texture::Wrap::mirror;
                fail("samplers[" + std::to_string(t.sampler) + "]", std::string(key) + " " + std::to_string(mode) +
                                                                        " is not 10497, 33071 or 33648");
            };
            out->wrap_s = wrap(sampler.wrapS, "wrapS");
            out->wrap_t = wrap(sampler.wrapT, "wrapT");
        }
        return textures_[index] = out;
    }

    // glTF's metallic-roughness model as ours: base colour (times its texture's mean)
    // split into a diffuse part (1 - metallic) and a Phong lobe (metallic) whose
    // exponent follows the roughness (n = 2 / roughness^4 - 2: the Phong lobe of the
    // GGX width alpha = roughness^2); a lobe of exponent 0 is diffuse and joins it. The
    // emission is emissiveFactor times KHR_materials_emissive_strength. brightest_colour:
    // the vertex colours' most, per channel, on the triangles that use it.
    Material material(const tinygltf::Material& m, const std::string& name, const std::string& where,
                      const Rgb& brightest_colour) {
        Material out;
        out.name = name;
        const auto& pbr = m.pbrMetallicRoughness;
        const auto factor = [&](const std::vector<double>& v, std::size_t n, const char* key) {
            if (v.size() < n) fail(where, std::string(key) + " has " + std::to_string(v.size()) + " values");
            Rgb c(v[0], v[1], v[2]);
            if (!c.allFinite() || (c < 0.0).any()) fail(where, std::string(key) + " is negative or not finite");
            return c;
        };
        Rgb base = factor(pbr.baseColorFactor, 4, "baseColorFactor");
        const Rgb tint = base;
        if (pbr.baseColorTexture.index >= 0) {
            out.texture = texture(pbr.baseColorTexture.index, where);
            if (out.texture)
                base = base * out.texture->mean();
            else
                warn("material '" + name + "': its base colour texture is not read (" +
                     texture_why_[pbr.baseColorTexture.index] + "); its factor is the colour");
        }
        const double metallic = pbr.metallicFactor, roughness = pbr.roughnessFactor;
        if (!(metallic >= 0.0 && metallic <= 1.0)) fail(where, "metallicFactor " + number(metallic) + " is not in 0..1");
        if (!(roughness >= 0.0 && roughness <= 1.0)) fail(where, "roughnessFactor " + number(roughness) + " is not in 0..1");
        if (pbr.metallicRoughnessTexture.index >= 0)
            warn("material '" + name + "': its metallic-roughness texture is not read (the factors are)");
        out.albedo = base * (1.0 - metallic);
        out.tint = tint * (1.0 - metallic);
        const double exponent = roughness > 0.0 ? std::min(2.0 / std::pow(roughness, 4) - 2.0, 1e4) : 1e4;
        if (metallic > 0.0 && exponent > 0.0) {
            out.specular = base * metallic;  // (the texture's mean colour: the lobe is one colour)
            out.exponent = exponent;
        } else {
            out.albedo = base;
            out.tint = tint;
        }
        Rgb emission = factor(m.emissiveFactor, 3, "emissiveFactor");
        // glTF keeps the factor in 0..1 (KHR_materials_emissive_strength scales it); a
        // file past that is read as it says.
        if ((emission > 1.0).any())
            warn("material '" + name + "': emissiveFactor (" + number(emission[0]) + ", " + number(emission[1]) + ", " +
                 number(emission[2]) + ") is past 1, which glTF does not allow (KHR_materials_emissive_strength "
                 "scales emission): read as given");
        if (const auto it = m.extensions.find("KHR_materials_emissive_strength"); it != m.extensions.end()) {
            if (!it->second.IsObject()) fail(where, "KHR_materials_emissive_strength is not an object");
            const auto& strength = it->second.Get("emissiveStrength");  // 1 where absent
            if (it->second.Has("emissiveStrength")) {
                if (!strength.IsNumber() || !(strength.GetNumberAsDouble() >= 0.0) ||
                    !std::isfinite(strength.GetNumberAsDouble()))
                    fail(where, "KHR_materials_emissive_strength: emissiveStrength " +
                                    (strength.IsNumber() ? number(strength.GetNumberAsDouble()) : std::string("(not a number)")) +
                                    " is not a number >= 0");
                emission *= strength.GetNumberAsDouble();
            }
        }
        if (m.emissiveTexture.index >= 0 && (emission > 0.0).any()) {
            if (const auto emitted = texture(m.emissiveTexture.index, where)) {
                emission = emission * emitted->mean();
                warn("material '" + name + "': its emissive texture is read as its mean colour " +
                     number(emitted->mean()[0]) + " " + number(emitted->mean()[1]) + " " + number(emitted->mean()[2]));
            } else {
                warn("material '" + name + "': its emissive texture is not read (" +
                     texture_why_[m.emissiveTexture.index] + "); its factor is the emission");
            }
        }
        out.emission = emission;
        out.two_sided = m.doubleSided;
        if (m.alphaMode == "BLEND" || m.alphaMode == "MASK")
            warn("material '" + name + "': alphaMode " + m.alphaMode + " is read as OPAQUE");
        out.colour_bound = brightest_colour;
        if (const auto sum = keep_energy(out, brightest_colour))
            warn("material '" + name + "': " + (out.texture ? "its base colour texture's brightest texels reflect "
                                                            : "reflects ") +
                 number(sum->first) + " of the light " + (out.texture ? "they receive" : "it receives") +
                 ": scaled by " + number(0.99 / sum->first));
        return out;
    }

    // Every material of the file under a name of its own ("(a.glb material 3)" where it
    // has none, "name #2" for the second of a name), and glTF's default material last
    // ("(a.glb default)"); they
    // are mapped (material()) once the triangles are placed, those used only.
    void read_materials() {
        std::map<std::string, int> seen;
        auto unique = [&](std::string name) {
            const int n = ++seen[name];
            return n == 1 ? name : name + " #" + std::to_string(n);
        };
        // Names the file does not give carry its name: another file's "material 0" is
        // another material.
        const std::string file = shown_.substr(shown_.find_last_of('/') == std::string::npos ? 0 : shown_.find_last_of('/') + 1);
        for (std::size_t i = 0; i < model_.materials.size(); ++i) {
            const auto& m = model_.materials[i];
            out_.materials.push_back(unique(m.name.empty() ? "(" + file + " material " + std::to_string(i) + ")" : m.name));
        }
        default_material_ = static_cast<int>(out_.materials.size());
        out_.materials.push_back(unique("(" + file + " default)"));
    }

    Material material_def(int index, const Rgb& brightest_colour) {
        const std::string& name = out_.materials[static_cast<std::size_t>(index)];
        if (index < default_material_)
            return material(model_.materials[static_cast<std::size_t>(index)], name,
                            "materials[" + std::to_string(index) + "]", brightest_colour);
        tinygltf::Material fallback;  // glTF's defaults: white, metallic 1, roughness 1
        fallback.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
        fallback.emissiveFactor = {0.0, 0.0, 0.0};
        fallback.pbrMetallicRoughness.metallicFactor = fallback.pbrMetallicRoughness.roughnessFactor = 1.0;
        return material(fallback, name, "a primitive without material", brightest_colour);
    }

    // ------------------------------------------------------------------ node tree
    std::vector<int> roots() const {
        if (!model_.scenes.empty()) {
            const int s = model_.defaultScene >= 0 ? model_.defaultScene : 0;
            if (static_cast<std::size_t>(s) >= model_.scenes.size())
                fail("scene", "default scene " + std::to_string(s) + " out of range");
            return model_.scenes[static_cast<std::size_t>(s)].nodes;
        }
        // No scene: every node that is nobody's child.
        std::vector<bool> child(model_.nodes.size(), false);
        for (const auto& n : model_.nodes)
            for (int c : n.children)
                if (c >= 0 && static_cast<std::size_t>(c) < child.size()) child[static_cast<std::size_t>(c)] = true;
        std::vector<int> out;
        for (std::size_t i = 0; i < child.size(); ++i)
            if (!child[i]) out.push_back(static_cast<int>(i));
        return out;
    }

    Matrix4 local(const tinygltf::Node& n, const std::string& where) {
        Matrix4 m = Matrix4::Identity();
        if (n.matrix.size() == 16) {
            for (int i = 0; i < 16; ++i) m(i % 4, i / 4) = n.matrix[static_cast<std::size_t>(i)];  // column-major
        } else {
            if (n.translation.size() == 3) m.block<3, 1>(0, 3) = Vec3(n.translation[0], n.translation[1], n.translation[2]);
            Eigen::Matrix3d rs = Eigen::Matrix3d::Identity();
            if (n.rotation.size() == 4) {
                const Eigen::Quaterniond q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);
                if (!(q.norm() > 0.0)) fail(where, "rotation is not a unit quaternion");
                // Exporters write floats: a length within 1e-3 of 1 is theirs to round.
                if (std::abs(q.norm() - 1.0) > 1e-3)
                    warn(where + ": rotation (" + number(n.rotation[0]) + ", " + number(n.rotation[1]) + ", " +
                         number(n.rotation[2]) + ", " + number(n.rotation[3]) + ") has length " + number(q.norm()) +
                         ", not 1: taken as the rotation of its direction");
                rs = q.normalized().toRotationMatrix();
            }
            if (n.scale.size() == 3) rs = rs * Vec3(n.scale[0], n.scale[1], n.scale[2]).asDiagonal();
            m.block<3, 3>(0, 0) = rs;
        }
        if (!m.allFinite()) fail(where, "its transform is not finite");
        return m;
    }

    // Depth first without recursion (a chain of nodes may be as long as the file
    // allows): a node's exit mark sits below its children on the stack.
    void place_tree(const std::vector<int>& roots) {
        struct Item {
            int node;
            Matrix4 parent;
            bool exit;
            std::string from;  // where its index is written: "nodes[3].children[1]", "scenes[0].nodes[2]"
        };
        std::vector<Item> stack;
        // The default scene's list (roots() read it where there are scenes).
        const std::string roots_at =
            model_.scenes.empty() ? "" : "scenes[" + std::to_string(std::max(model_.defaultScene, 0)) + "].nodes";
        for (std::size_t r = roots.size(); r-- > 0;)
            stack.push_back({roots[r], Matrix4::Identity(), false,
                             roots_at.empty() ? "nodes[" + std::to_string(roots[r]) + "]"
                                              : roots_at + "[" + std::to_string(r) + "]"});
        while (!stack.empty()) {
            const Item item = stack.back();
            stack.pop_back();
            if (item.exit) {
                on_path_.erase(item.node);
                continue;
            }
            const int index = item.node;
            const std::string where = "nodes[" + std::to_string(index) + "]";
            if (index < 0 || static_cast<std::size_t>(index) >= model_.nodes.size())
                fail(item.from, "node " + std::to_string(index) + " out of range (" +
                                    std::to_string(model_.nodes.size()) + " nodes)");
            if (const auto [it, first] = placed_.emplace(index, item.from); !first)
                fail(where, on_path_.count(index) ? "is its own ancestor (the node tree has a cycle)"
                                                  : "is placed twice, by " + it->second + " and by " + item.from +
                                                        " (a node has one parent, and a root none)");
            on_path_.insert(index);
            const auto& node = model_.nodes[static_cast<std::size_t>(index)];
            const Matrix4 world = item.parent * local(node, where);
            if (!world.allFinite()) fail(where, "its transform, times its parents', is not finite");
            if (node.mesh >= 0) place_mesh(node, world, where);
            if (node.camera >= 0) place_camera(node, world, where);
            if (const auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end())
                place_light(it->second, world, where);
            stack.push_back({index, Matrix4::Identity(), true, ""});
            for (std::size_t c = node.children.size(); c-- > 0;)
                stack.push_back({node.children[c], world, false, where + ".children[" + std::to_string(c) + "]"});
        }
    }

    // --------------------------------------------------------------- accessors
    std::pair<const unsigned char*, std::size_t> buffer_view(int index, const std::string& where) const {
        if (index < 0 || static_cast<std::size_t>(index) >= model_.bufferViews.size())
            fail(where, "bufferView " + std::to_string(index) + " out of range");
        const auto& view = model_.bufferViews[static_cast<std::size_t>(index)];
        if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size())
            fail(where, "bufferViews[" + std::to_string(index) + "]: buffer " + std::to_string(view.buffer) +
                            " out of range");
        const auto& data = model_.buffers[static_cast<std::size_t>(view.buffer)].data;
        if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
            fail(where, "bufferViews[" + std::to_string(index) + "]: bytes " + std::to_string(view.byteOffset) + ".." +
                            std::to_string(view.byteOffset + view.byteLength) + " lie outside its buffer of " +
                            std::to_string(data.size()) + " bytes (missing or short buffer?)");
        return {data.data() + view.byteOffset, view.byteLength};
    }

    // "VEC2 of UNSIGNED_SHORT", for messages.
    std::string accessor_type(int index) const {
        const auto& a = model_.accessors[static_cast<std::size_t>(index)];
        const int n = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
        const char* type = a.type == TINYGLTF_TYPE_SCALAR ? "SCALAR"
                           : a.type == TINYGLTF_TYPE_VEC2 ? "VEC2"
                           : a.type == TINYGLTF_TYPE_VEC3 ? "VEC3"
                           : a.type == TINYGLTF_TYPE_VEC4 ? "VEC4"
                                                          : nullptr;
        const std::string shape = type ? type : n == 4 ? "MAT2" : n == 9 ? "MAT3" : n == 16 ? "MAT4" : "an unknown type";
        switch (a.componentType) {
            case TINYGLTF_COMPONENT_TYPE_BYTE: return shape + " of BYTE";
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return shape + " of UNSIGNED_BYTE";
            case TINYGLTF_COMPONENT_TYPE_SHORT: return shape + " of SHORT";
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return shape + " of UNSIGNED_SHORT";
            case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return shape + " of UNSIGNED_INT";
            case TINYGLTF_COMPONENT_TYPE_FLOAT: return shape + " of FLOAT";
            default: return shape + " of componentType " + std::to_string(a.componentType);
        }
    }

    Elements elements(int index, const std::string& where, const char* what) const {
        const std::string at = where + ": " + what;
        if (index < 0 || static_cast<std::size_t>(index) >= model_.accessors.size())
            fail(at, "accessor " + std::to_string(index) + " out of range");
        const auto& a = model_.accessors[static_cast<std::size_t>(index)];
        const std::string named = at + " (accessors[" + std::to_string(index) + "])";
        if (a.sparse.isSparse) fail(named, "sparse accessors are not read");
        if (a.bufferView < 0) fail(named, "has no bufferView");
        const auto [base, length] = buffer_view(a.bufferView, named);
        Elements e;
        e.component = a.componentType;
        e.components = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
        const int bytes = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType));
        if (e.components <= 0 || bytes <= 0) fail(named, "unknown type or componentType");
        const std::size_t size = static_cast<std::size_t>(e.components) * static_cast<std::size_t>(bytes);
        const std::size_t declared = model_.bufferViews[static_cast<std::size_t>(a.bufferView)].byteStride;
        // Indices are told by their type before their size: a float or strided index
        // accessor is not "too long for its view".
        if (std::string(what) == "indices") {
            if (e.components != 1) fail(named, "expected SCALAR");
            if (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
                fail(named, "expected UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, got componentType " +
                                std::to_string(a.componentType));
            if (declared != 0 && declared != size)  // (one of the element's own size reads alike)
                fail(named, "its bufferView has a byteStride (" + std::to_string(declared) +
                                "), which glTF does not allow for indices");
        }
        e.stride = declared == 0 ? size : declared;
        if (e.stride < size) fail(named, "byteStride " + std::to_string(e.stride) + " is less than an element");
        e.count = a.count;
        if (e.count == 0) fail(named, "count 0 (glTF asks for at least 1)");
        if (e.count > 0 && (a.byteOffset > length || size > length - a.byteOffset ||
                            (e.count - 1) > (length - a.byteOffset - size) / e.stride))
            fail(named, std::to_string(e.count) + " elements from byte " + std::to_string(a.byteOffset) +
                            " do not fit in its bufferView of " + std::to_string(length) + " bytes");
        e.base = base + a.byteOffset;
        return e;
    }

    Elements vec3s(int index, const std::string& where, const char* what) const {
        const Elements e = elements(index, where, what);
        if (e.components != 3 || e.component != TINYGLTF_COMPONENT_TYPE_FLOAT)
            fail(where + ": " + what, "expected VEC3 of FLOAT, got " + accessor_type(index));
        return e;
    }
    static Vec3 vec3_at(const Elements& e, std::size_t i) {
        float f[3];
        std::memcpy(f, e.base + i * e.stride, sizeof f);
        return Vec3(f[0], f[1], f[2]);
    }

    // KHR_texture_transform: (s, t) = offset + R(rotation) (scale * uv), R = [cos sin;
    // -sin cos] (the extension's matrices, in its order), and its texCoord in place of
    // the texture's.
    struct UvTransform {
        Eigen::Matrix2d linear = Eigen::Matrix2d::Identity();
        Uv offset = Uv::Zero();
        int tex_coord = 0;
    };
    UvTransform uv_transform(const tinygltf::TextureInfo& info, const std::string& where) const {
        UvTransform out;
        out.tex_coord = info.texCoord;
        const auto it = info.extensions.find("KHR_texture_transform");
        if (it == info.extensions.end()) return out;
        const std::string at = where + ": KHR_texture_transform";
        const tinygltf::Value& t = it->second;
        if (!t.IsObject()) fail(at, "is not an object");
        const auto number = [&](const tinygltf::Value& v, const char* key) {
            if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble())) fail(at, std::string(key) + " is not a finite number");
            return v.GetNumberAsDouble();
        };
        const auto pair = [&](const char* key, Uv fallback) {
            if (!t.Has(key)) return fallback;
            const tinygltf::Value& v = t.Get(key);
            if (!v.IsArray() || v.ArrayLen() != 2) fail(at, std::string(key) + " is not two numbers");
            return Uv(number(v.Get(0), key), number(v.Get(1), key));
        };
        out.offset = pair("offset", Uv::Zero());
        const Uv scale = pair("scale", Uv::Ones());
        const double r = t.Has("rotation") ? number(t.Get("rotation"), "rotation") : 0.0;
        Eigen::Matrix2d rotation;
        rotation << std::cos(r), std::sin(r), -std::sin(r), std::cos(r);
        out.linear = rotation * scale.asDiagonal();
        if (t.Has("texCoord")) {
            const tinygltf::Value& c = t.Get("texCoord");
            if (!c.IsInt() || c.GetNumberAsInt() < 0) fail(at, "texCoord is not a whole number >= 0");
            out.tex_coord = c.GetNumberAsInt();
        }
        return out;
    }

    // Texture coordinates: floats, or unsigned bytes or shorts read as 0..1 (glTF allows
    // only normalized ones).
    static Uv uv_at(const Elements& e, std::size_t i) {
        const unsigned char* p = e.base + i * e.stride;
        if (e.component == TINYGLTF_COMPONENT_TYPE_FLOAT) {
            float f[2];
            std::memcpy(f, p, sizeof f);
            return Uv(f[0], f[1]);
        }
        if (e.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return Uv(p[0] / 255.0, p[1] / 255.0);
        std::uint16_t u[2];
        std::memcpy(u, p, sizeof u);
        return Uv(u[0] / 65535.0, u[1] / 65535.0);
    }

    static Rgb colour_at(const Elements& e, std::size_t i) {
        const unsigned char* p = e.base + i * e.stride;
        if (e.component == TINYGLTF_COMPONENT_TYPE_FLOAT) {
            float f[3];
            std::memcpy(f, p, sizeof f);
            return Rgb(f[0], f[1], f[2]);
        }
        if (e.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return Rgb(p[0], p[1], p[2]) / 255.0;
        std::uint16_t u[3];
        std::memcpy(u, p, sizeof u);
        return Rgb(u[0], u[1], u[2]) / 65535.0;
    }

    std::vector<std::uint32_t> indices(int index, std::size_t vertices, const std::string& where) const {
        std::vector<std::uint32_t> out;
        if (index < 0) {
            out.resize(vertices);
            for (std::size_t i = 0; i < vertices; ++i) out[i] = static_cast<std::uint32_t>(i);
            return out;
        }
        const Elements e = elements(index, where, "indices");
        if (e.components != 1) fail(where + ": indices", "expected SCALAR");
        out.resize(e.count);
        for (std::size_t i = 0; i < e.count; ++i) {
            const unsigned char* p = e.base + i * e.stride;
            std::uint32_t v = 0;
            if (e.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
                v = *p;
            } else if (e.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
                std::uint16_t s;
                std::memcpy(&s, p, 2);
                v = s;
            } else if (e.component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
                std::memcpy(&v, p, 4);
            } else {
                fail(where + ": indices", "expected UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT");
            }
            if (v >= vertices)
                fail(where + ": indices", "index " + std::to_string(v) + " at " + std::to_string(i) +
                                              " out of range (" + std::to_string(vertices) + " vertices)");
            out[i] = v;
        }
        return out;
    }

    // ------------------------------------------------------------------ placing
    // A primitive as its placements use it: its triangles over the vertices they use
    // (not the whole POSITION accessor, which other primitives may share), decoded at
    // its first placement.
    struct Primitive {
        bool surface = false;
        int material = -1;
        std::vector<Vec3> positions, normals;  // normals: empty, or one per position
        std::vector<Uv> uvs;                   // its base colour texture's TEXCOORD_n: empty, or one per position
        std::vector<Rgb> colours;              // COLOR_0 (linear, clamped to [0, 1]): empty, or one per position
        std::vector<std::array<std::uint32_t, 3>> triangles;
    };

    // How many triangles a primitive gives, from its counts alone.
    static std::size_t triangle_count(int mode, std::size_t indices) {
        if (mode == TINYGLTF_MODE_TRIANGLES) return indices / 3;
        return indices >= 3 ? indices - 2 : 0;
    }

    Primitive decode(int mesh_index, std::size_t p) {
        const auto& prim = model_.meshes[static_cast<std::size_t>(mesh_index)].primitives[p];
        const std::string at = "meshes[" + std::to_string(mesh_index) + "].primitives[" + std::to_string(p) + "]";
        Primitive out;
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
            warn(at + ": points or lines (mode " + std::to_string(prim.mode) + ") are not surfaces: skipped");
            return out;
        }
        out.surface = true;
        const auto position = prim.attributes.find("POSITION");
        if (position == prim.attributes.end()) fail(at, "has no POSITION");
        const Elements positions = vec3s(position->second, at, "POSITION");
        const std::size_t count = prim.indices >= 0 ? elements(prim.indices, at, "indices").count : positions.count;
        if (triangle_count(prim.mode, count) > max_triangles_ - std::min(max_triangles_, out_.triangles.size()))
            fail(at, "more than " + std::to_string(max_triangles_) + " triangles once every node is placed");
        const std::vector<std::uint32_t> idx = indices(prim.indices, positions.count, at);
        std::vector<std::array<std::uint32_t, 3>> tris;
        if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
            for (std::size_t i = 0; i + 2 < idx.size(); i += 3) tris.push_back({idx[i], idx[i + 1], idx[i + 2]});
        } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
            for (std::size_t i = 0; i + 2 < idx.size(); ++i)
                tris.push_back(i % 2 == 0 ? std::array{idx[i], idx[i + 1], idx[i + 2]}
                                          : std::array{idx[i + 1], idx[i], idx[i + 2]});
        } else {
            for (std::size_t i = 1; i + 1 < idx.size(); ++i) tris.push_back({idx[0], idx[i], idx[i + 1]});
        }
        std::optional<Elements> normals;
        if (const auto n = prim.attributes.find("NORMAL"); n != prim.attributes.end()) {
            normals = vec3s(n->second, at, "NORMAL");
            if (normals->count != positions.count)
                fail(at + ": NORMAL", std::to_string(normals->count) + " normals for " +
                                          std::to_string(positions.count) + " positions");
        }
        out.material = default_material_;
        if (prim.material >= 0) {
            if (static_cast<std::size_t>(prim.material) >= model_.materials.size())
                fail(at, "material " + std::to_string(prim.material) + " out of range");
            out.material = prim.material;
        }
        // The texture coordinates its material's base colour texture reads (through its
        // KHR_texture_transform, where it has one).
        std::optional<Elements> uvs;
        std::string uv_key;
        UvTransform transform;
        if (out.material < default_material_) {
            const auto& info = model_.materials[static_cast<std::size_t>(out.material)].pbrMetallicRoughness.baseColorTexture;
            transform = uv_transform(info, "materials[" + std::to_string(out.material) + "].pbrMetallicRoughness.baseColorTexture");
            uv_key = "TEXCOORD_" + std::to_string(transform.tex_coord);
            if (info.index >= 0)
                if (const auto u = prim.attributes.find(uv_key); u != prim.attributes.end()) {
                    uvs = elements(u->second, at, uv_key.c_str());
                    const bool read = uvs->components == 2 &&
                                      (uvs->component == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                                       uvs->component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                       uvs->component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
                    if (!read)
                        fail(at + ": " + uv_key, "expected VEC2 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT, got " +
                                                     accessor_type(u->second));
                    if (uvs->count != positions.count)
                        fail(at + ": " + uv_key, std::to_string(uvs->count) + " texture coordinates for " +
                                                     std::to_string(positions.count) + " positions");
                }
        }
        // COLOR_0, which multiplies the base colour (glTF 2.0, 3.7.2.1: VEC3 or VEC4 of
        // FLOAT, or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT; linear, alpha unread).
        std::optional<Elements> colours;
        // An unlit material's colours are what it looks like, not what it reflects (a
        // baked .glb's radiance): read as a white surface, as its base colour is.
        const bool unlit = out.material < default_material_ &&
                           model_.materials[static_cast<std::size_t>(out.material)].extensions.count("KHR_materials_unlit");
        if (const auto c = prim.attributes.find("COLOR_0"); c != prim.attributes.end() && unlit) {
            warn(at + ": COLOR_0 of an unlit material (KHR_materials_unlit) is its look, not its albedo: not read");
        } else if (c != prim.attributes.end()) {
            colours = elements(c->second, at, "COLOR_0");
            const bool read = (colours->components == 3 || colours->components == 4) &&
                              (colours->component == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                               colours->component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                               colours->component == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
            if (!read)
                fail(at + ": COLOR_0", "expected VEC3 or VEC4 of FLOAT, UNSIGNED_BYTE or UNSIGNED_SHORT, got " +
                                           accessor_type(c->second));
            if (colours->count != positions.count)
                fail(at + ": COLOR_0", std::to_string(colours->count) + " colours for " +
                                           std::to_string(positions.count) + " positions");
        }
        bool clamped = false;
        // The vertices the triangles use, in order of first use.
        std::unordered_map<std::uint32_t, std::uint32_t> remap;
        for (auto& t : tris)
            for (auto& v : t) {
                const auto [it, added] = remap.emplace(v, static_cast<std::uint32_t>(out.positions.size()));
                if (added) {
                    out.positions.push_back(vec3_at(positions, v));
                    if (normals) out.normals.push_back(vec3_at(*normals, v));
                    if (uvs) {
                        const Uv st = transform.offset + transform.linear * uv_at(*uvs, v);
                        if (!st.allFinite()) fail(at + ": " + uv_key, "texture coordinate " + std::to_string(v) + " is not finite");
                        out.uvs.push_back(st);
                    }
                    if (colours) {
                        const Rgb c = colour_at(*colours, v);
                        if (!c.allFinite()) fail(at + ": COLOR_0", "colour " + std::to_string(v) + " is not finite");
                        clamped = clamped || (c < 0.0).any() || (c > 1.0).any();
                        out.colours.push_back(c.max(0.0).min(1.0));
                    }
                }
                v = it->second;
            }
        if (clamped) warn(at + ": COLOR_0 has values outside [0, 1] (glTF asks for 0 to 1): clamped");
        out.triangles = std::move(tris);
        return out;
    }

    void place_mesh(const tinygltf::Node& node, const Matrix4& world, const std::string& where) {
        if (static_cast<std::size_t>(node.mesh) >= model_.meshes.size())
            fail(where, "mesh " + std::to_string(node.mesh) + " out of range");
        const auto& mesh = model_.meshes[static_cast<std::size_t>(node.mesh)];
        if (mesh.primitives.empty())
            warn("meshes[" + std::to_string(node.mesh) + "] (placed by " + where +
                 ") has no primitives (glTF asks for at least 1): it places nothing");
        const std::string group = !node.name.empty() ? node.name : !mesh.name.empty() ? mesh.name : where;
        const int group_index = static_cast<int>(out_.groups.size());
        out_.groups.push_back(group);
        const Eigen::Matrix3d linear = world.block<3, 3>(0, 0);
        const Eigen::Matrix3d normal_matrix = linear.inverse().transpose();
        const bool flipped = linear.determinant() < 0.0;  // a mirror turns front faces round
        for (std::size_t p = 0; p < mesh.primitives.size(); ++p) {
            // Placements are bounded too: a mesh of many empty primitives under many
            // nodes would otherwise take time without end.
            if (++placements_ > kMaxPlacements)
                fail(where, "more than " + std::to_string(kMaxPlacements) + " primitives once every node is placed");
            const std::pair<int, std::size_t> key(node.mesh, p);
            auto it = decoded_.find(key);
            if (it == decoded_.end()) it = decoded_.emplace(key, decode(node.mesh, p)).first;
            const Primitive& prim = it->second;
            if (!prim.surface) continue;
            const std::string at = "meshes[" + std::to_string(node.mesh) + "].primitives[" + std::to_string(p) + "]";
            if (prim.triangles.size() > max_triangles_ - std::min(max_triangles_, out_.triangles.size()))
                fail(at, "more than " + std::to_string(max_triangles_) + " triangles once every node is placed");
            // The vertices this primitive uses, placed in the world.
            const std::size_t first = out_.vertices.size();
            if (first + prim.positions.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
                fail(at, "more than 2^31 vertices once every node is placed");
            for (const auto& v : prim.positions) {
                const Vec3 w = (world * v.homogeneous()).head<3>();
                if (!w.allFinite()) fail(at, "a position is not finite");
                out_.vertices.push_back(w);
            }
            for (auto t : prim.triangles) {
                if (flipped) std::swap(t[1], t[2]);
                out_.triangles.push_back({static_cast<int>(first + t[0]), static_cast<int>(first + t[1]),
                                          static_cast<int>(first + t[2])});
                out_.triangle_material.push_back(prim.material);
                out_.triangle_group.push_back(group_index);
                std::array<Vec3, 3> corner;
                for (std::size_t k = 0; k < 3; ++k) {
                    if (prim.normals.empty()) {
                        corner[k] = Vec3::Zero();
                        continue;
                    }
                    const Vec3 n = normal_matrix * prim.normals[t[k]];
                    // A zero or broken normal leaves its corner to the computed normals.
                    corner[k] = n.allFinite() && n.norm() > 0.0 ? n.normalized() : Vec3::Zero();
                }
                out_.normals.push_back(corner);
                constexpr double none = std::numeric_limits<double>::quiet_NaN();
                if (prim.uvs.empty())
                    out_.uvs.push_back({Uv(none, none), Uv(none, none), Uv(none, none)});
                else
                    out_.uvs.push_back({prim.uvs[t[0]], prim.uvs[t[1]], prim.uvs[t[2]]});
                if (prim.colours.empty())
                    out_.colours.push_back({Rgb::Constant(none), Rgb::Constant(none), Rgb::Constant(none)});
                else
                    out_.colours.push_back({prim.colours[t[0]], prim.colours[t[1]], prim.colours[t[2]]});
            }
        }
    }

    void place_camera(const tinygltf::Node& node, const Matrix4& world, const std::string& where) {
        if (static_cast<std::size_t>(node.camera) >= model_.cameras.size())
            fail(where, "camera " + std::to_string(node.camera) + " out of range");
        if (out_.camera) return;  // the first camera counts
        const auto& cam = model_.cameras[static_cast<std::size_t>(node.camera)];
        if (cam.type != "perspective") {
            warn(where + ": an " + cam.type + " camera is not read (the next perspective camera is taken, or else the "
                         "model is framed)");
            return;
        }
        const Vec3 eye = world.block<3, 1>(0, 3);
        const Vec3 forward = -world.block<3, 1>(0, 2), up = world.block<3, 1>(0, 1);
        const double fov = cam.perspective.yfov * 180.0 / M_PI;
        if (!(forward.norm() > 0.0) || !(up.cross(forward).norm() > 1e-9 * up.norm() * forward.norm()) ||
            !(fov > 0.0 && fov < 180.0)) {
            warn(where + ": its camera is degenerate (the next perspective camera is taken, or else the model is "
                         "framed)");
            return;
        }
        Camera c;
        c.eye = eye;
        c.target = eye + forward.normalized();
        c.up = up.normalized();
        c.fov_y = fov;
        const double aspect = cam.perspective.aspectRatio;
        if (aspect > 0.0 && aspect <= 16.0) {
            c.height = 512;
            c.width = std::max(1, static_cast<int>(std::lround(512 * aspect)));
        }
        out_.camera = c;
    }

    void place_light(const tinygltf::Value& ext, const Matrix4& world, const std::string& where) {
        if (!ext.IsObject()) fail(where, "KHR_lights_punctual is not an object");
        const auto& index = ext.Get("light");
        if (!index.IsInt() || index.Get<int>() < 0 || static_cast<std::size_t>(index.Get<int>()) >= model_.lights.size())
            fail(where, "KHR_lights_punctual: light index missing or out of range");
        const auto& light = model_.lights[static_cast<std::size_t>(index.Get<int>())];
        const std::string named = "light '" + (light.name.empty() ? std::to_string(index.Get<int>()) : light.name) + "'";
        if (light.type != "point" && light.type != "spot" && light.type != "directional") {
            const bool vowel = !light.type.empty() && std::string("aeiou").find(light.type[0]) != std::string::npos;
            warn(where + ": " + named + (vowel ? ": an " : ": a ") + light.type +
                 " light is not read (point, spot and directional lights are)");
            return;
        }
        Rgb colour = Rgb::Ones();
        if (light.color.size() == 3) colour = Rgb(light.color[0], light.color[1], light.color[2]);
        if (!std::isfinite(light.intensity) || light.intensity < 0.0)
            fail(where, named + ": intensity " + number(light.intensity) + " is negative or not finite");
        if (!colour.allFinite() || (colour < 0.0).any())
            fail(where, named + ": color [" + number(colour[0]) + ", " + number(colour[1]) + ", " + number(colour[2]) +
                            "] is negative or not finite");
        const Rgb intensity = colour * light.intensity;
        if (!intensity.allFinite()) fail(where, named + ": intensity times color is not finite");
        if (light.type == "directional") {
            // Along the node's -z; intensity in lux: the irradiance of a surface facing it.
            const Vec3 direction = -world.block<3, 1>(0, 2);
            if (!(direction.norm() > 0.0))
                fail(where, named + ": its node's transform has no -z direction (a scale of 0)");
            out_.directional_lights.push_back({direction.normalized(), intensity, shown_ + ": " + named});
            return;
        }
        if (light.range > 0.0) warn(where + ": " + named + ": its range is not read (the light reaches everywhere)");
        PointLight p;
        p.position = world.block<3, 1>(0, 3);
        p.intensity = intensity;  // candela (lm/sr): the scene's radiant intensity unit
        if (light.type == "spot") {
            // Along the node's -z; cones in radians from that axis, 0 <= inner < outer <= pi/2.
            const double inner = light.spot.innerConeAngle, outer = light.spot.outerConeAngle;
            if (!(outer > 0.0 && outer <= M_PI / 2 + 1e-9))
                fail(where, named + ": outerConeAngle " + number(outer) + " is not in (0, pi/2]");
            if (!(inner >= 0.0 && inner < outer))
                fail(where, named + ": innerConeAngle " + number(inner) + " is not in [0, outerConeAngle = " +
                                number(outer) + ")");
            const Vec3 axis = -world.block<3, 1>(0, 2);
            if (!(axis.norm() > 0.0)) fail(where, named + ": its node's transform has no -z direction (a scale of 0)");
            p.axis = axis.normalized();
            p.cos_inner = std::cos(inner);
            p.cos_outer = std::cos(outer);
        }
        out_.point_lights.push_back(p);
    }

    const tinygltf::Model& model_;
    const std::string& shown_;
    const Files& files_;  // the asset's folder: why an image file gave nothing
    std::size_t max_triangles_;
    MeshData& out_;
    int default_material_ = -1;
    std::map<int, std::string> placed_;  // each node placed, and where its index was written
    std::set<int> on_path_;
    std::map<std::pair<int, std::size_t>, Primitive> decoded_;
    std::size_t placements_ = 0;
    std::map<int, std::shared_ptr<const Texture>> textures_;    // per texture, made once (null: not read)
    std::map<int, std::shared_ptr<const TexelImage>> images_;  // per image, decoded once
    std::map<int, std::string> texture_why_, image_why_;        // why one is not read
};

}  // namespace

MeshData read_gltf(std::string_view content, bool binary, const std::string& shown,
                   const std::optional<std::string>& folder, std::size_t max_triangles) {
    const std::string_view json_text = binary ? glb_json(content, shown) : content;
    check_nesting(json_text, shown);
    Files files{folder, {}, 0};
    std::vector<std::string> unknown;
    {  // The document once, for the checks tinygltf leaves out (not JSON: tinygltf says
       // why), and gone before tinygltf reads it.
        const nlohmann::json doc = nlohmann::json::parse(json_text.begin(), json_text.end(), nullptr, false);
        check_resources(doc, shown, files);
        check_ids(doc, shown);
        check_lights(doc, shown);
        unknown = unknown_keys(doc, shown);
    }
    tinygltf::TinyGLTF loader;
    loader.SetFsCallbacks({&file_exists, &expand_path, &read_file, &write_file, &files});
    loader.SetImageLoader(&keep_image, nullptr);
    loader.SetStoreOriginalJSONForExtrasAndExtensions(false);
    tinygltf::Model model;
    std::string err, warn;
    const std::string base = folder.value_or("");
    bool ok = false;
    MeshData out;
    // tinygltf and nlohmann may throw (a std::out_of_range from a buffer of byteLength
    // 0 beside a BIN chunk, a JSON type error): each is this file's fault, in one line.
    try {
        ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(content.data()),
                                                  static_cast<unsigned int>(content.size()), base)
                    : loader.LoadASCIIFromString(&model, &err, &warn, content.data(),
                                                 static_cast<unsigned int>(content.size()), base);
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        throw SceneError(shown, "", std::string("not a valid glTF 2.0 file: ") + first_line(e.what()));
    }
    if (!ok) throw SceneError(shown, "", "not a valid glTF 2.0 file: " + first_line(err.empty() ? warn : err));
    out.warnings = std::move(unknown);
    Reader(model, shown, files, max_triangles, out).read();
    out.resources = std::move(files.read);
    // No file gives normals at every corner: the computed ones serve.
    bool any = false;
    for (const auto& n : out.normals) any = any || n[0] != Vec3::Zero() || n[1] != Vec3::Zero() || n[2] != Vec3::Zero();
    if (!any) out.normals.clear();
    // Nor texture coordinates, where no textured primitive gives them.
    if (std::none_of(out.uvs.begin(), out.uvs.end(), [](const auto& c) { return c[0].allFinite(); })) out.uvs.clear();
    // Nor vertex colours, where no primitive gives them.
    if (std::none_of(out.colours.begin(), out.colours.end(), [](const auto& c) { return c[0].allFinite(); }))
        out.colours.clear();
    return out;
}

}  // namespace raybundle::scenes::mesh_detail
