#include "scenes/errors.h"
#include "scenes/mesh_file.h"
#include "scenes/mesh_readers.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <vector>

namespace raybundle::scenes {

namespace {

std::string number(double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", x);
    return text;
}

// The folder of a path ("" for a bare name) and a name in it.
std::string folder_of(const std::string& path) {
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}
std::string in_folder(const std::string& folder, const std::string& name) {
    return !name.empty() && name[0] == '/' ? name : folder + name;
}

// The texture of an image file (a PNG or JPEG, repeated past its edges), decoded once
// per file in `decoded`, or nothing for a file that is missing or not an image it can
// read, with why in `why`.
using Decoded = std::map<std::string, std::shared_ptr<const Texture>>;
std::shared_ptr<const Texture> texture_file(const std::string& path, const std::string& shown, Decoded& decoded,
                                            std::string& why) {
    if (const auto it = decoded.find(path); it != decoded.end() && it->second) return it->second;
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
        why = "no such file";
        return nullptr;
    }
    if (!std::filesystem::is_regular_file(path, ec)) {
        why = "not a regular file";
        return nullptr;
    }
    try {
        auto image = decode_image(read_input_file(path, path, "texture", kMaxSceneFileBytes), &why);
        if (!image) return nullptr;
        auto texture = std::make_shared<Texture>();
        texture->name = path;
        texture->shown = shown;
        texture->image = std::make_shared<const TexelImage>(std::move(*image));
        return decoded[path] = texture;
    } catch (const SceneError& e) {
        why = e.problem();
        return nullptr;
    }
}

// A material of the scene from an MTL's: Kd the albedo, Ke the emission, Ks and Ns the
// Phong lobe where illum asks for highlights (not 0 or 1), scaled down where Kd + Ks
// reaches 1; a lobe of exponent 0 is Lambertian and joins the albedo, and Blender's Ks
// is no lobe (below). What is read otherwise or not at all is a warning.
Material from_mtl(const MtlMaterial& m, const std::string& file, const std::string& folder,
                  std::vector<std::string>& warnings, std::vector<std::string>& files, Decoded& decoded) {
    Material out;
    out.name = m.name;
    out.albedo = m.kd;
    out.emission = m.ke;
    const std::string named = file + ": material '" + m.name + "'";
    // Blender's Ks is its Principled BSDF's specular: a dielectric's Fresnel reflection
    // (0.08 Ks at normal incidence, more at grazing angles), not a lobe of Ks. As a glTF
    // dielectric's (metallic 0), it is no lobe here: the surface is diffuse, so that a
    // scene exported from Blender is not glossy for every material's default 0.5.
    if (m.illum != 0 && m.illum != 1 && (m.ks > 0.0).any() && !m.blender) {
        if (m.ns > 0.0) {
            out.specular = m.ks;
            out.exponent = m.ns;
        } else {
            out.albedo += m.ks;  // (n + 2) / 2pi cos^0: a Lambertian reflector of Ks
        }
    }
    if (m.illum > 2)
        warnings.push_back(named + ": illum " + std::to_string(m.illum) +
                           " (reflection, refraction or glass) is read as 2 (diffuse and Phong highlights)");
    // A texture is the albedo, texel by texel where the faces give texture coordinates
    // (the texture itself, not times Kd, as Blender's importer shows it); `albedo` is its
    // mean.
    if (!m.map_kd.empty()) {
        // The name as read, else (no such file) the statement's last word.
        std::string map = m.map_kd, why;
        std::error_code ec;
        if (!std::filesystem::exists(in_folder(folder, map), ec) && !m.map_kd_last.empty() &&
            std::filesystem::exists(in_folder(folder, m.map_kd_last), ec))
            map = m.map_kd_last;
        // A path of the exporter's machine ("C:/Users/bob/textures/wood.png"): the file
        // of that name beside the MTL, where the asset's textures travel with it.
        if (const auto slash = map.find_last_of('/'); slash != std::string::npos &&
            !std::filesystem::exists(in_folder(folder, map), ec) &&
            std::filesystem::exists(in_folder(folder, map.substr(slash + 1)), ec))
            map = map.substr(slash + 1);
        if (auto texture = texture_file(in_folder(folder, map), map, decoded, why)) {
            out.albedo = texture->mean();
            if (m.map_kd_clamp) {  // the same texels, clamped
                auto clamped = std::make_shared<Texture>(*texture);
                clamped->wrap_s = clamped->wrap_t = Texture::Wrap::clamp;
                texture = std::move(clamped);
            }
            out.texture = std::move(texture);
            // -o, -s in (u, v), v up: in (s, t), t = 1 - v, t' = 1 - o_v - s_v (1 - t).
            out.uv_linear = m.map_kd_scale.asDiagonal();
            out.uv_offset = Uv(m.map_kd_offset.x(), 1.0 - m.map_kd_offset.y() - m.map_kd_scale.y());
            files.push_back(in_folder(folder, map));
        } else {
            const bool relative = !map.empty() && map[0] != '/';
            warnings.push_back(named + ": its texture " + map + " is not read (" + why +
                               (why == "no such file" && relative ? " beside " + file : std::string()) + "); its Kd " +
                               number(m.kd[0]) + " " + number(m.kd[1]) + " " + number(m.kd[2]) + " is the colour");
        }
    }
    if (const auto sum = mesh_detail::keep_energy(out, Rgb::Ones()))
        warnings.push_back(named + (out.texture ? ": its texture's brightest texels + Ks = " : ": Kd + Ks = ") +
                           number(sum->first) + " in channel " + "rgb"[sum->second] +
                           ": both scaled by " + number(0.99 / sum->first) + " (a surface reflects less than it receives)");
    return out;
}

bool same_values(const Material& a, const Material& b) {
    const bool same_texture = a.texture && b.texture ? a.texture->same(*b.texture) && (a.tint == b.tint).all() &&
                                                           a.uv_linear == b.uv_linear && a.uv_offset == b.uv_offset
                                                     : !a.texture && !b.texture;
    return (a.albedo == b.albedo).all() && (a.emission == b.emission).all() && (a.specular == b.specular).all() &&
           a.exponent == b.exponent && a.two_sided == b.two_sided && (a.colour_bound == b.colour_bound).all() &&
           same_texture;
}

// The scene's index for material m, defined by the mesh `shown`: an earlier mesh's of
// that name with the same values, or m added. Where an earlier mesh's of that name
// differs (every default material of Blender is "Material"), m is another material,
// "NAME (shown)", and a warning says so. Emission past 1e15 (as the scene file's) is
// refused. Returns -1 - its index where an earlier mesh's is the same, or where the
// scene file's own materials (the first `scene_materials`) define "NAME (shown)".
int add_brought(Scene& scene, std::size_t scene_materials, Material m, const std::string& shown,
                const std::string& where) {
    for (int k = 0; k < 3; ++k)
        if (!(m.emission[k] <= 1e15))
            throw SceneError(shown, where, "material '" + m.name + "': emission " + number(m.emission[k]) +
                                               " is too large (at most 1e+15)");
    const std::string name = m.name;
    for (int i = 0;; ++i) {
        const std::string tried = i == 0 ? name : i == 1 ? name + " (" + shown + ")" : name + " (" + shown + ", " + std::to_string(i) + ")";
        const int at = scene.find_material(tried);
        if (i > 0 && at >= 0 && static_cast<std::size_t>(at) < scene_materials) return -1 - at;  // the scene's own
        if (at < 0) {
            if (i > 0)
                scene.warnings.push_back(shown + ": its material '" + name + "' differs from the one of that name an earlier "
                                         "mesh brought: it is '" + tried + "' here (-D '" + material_setting(tried) +
                                         "={...}' sets it)");
            m.name = tried;
            return scene.add_material(std::move(m));
        }
        if (same_values(scene.materials[static_cast<std::size_t>(at)], m)) return -1 - at;
    }
}

}  // namespace

namespace mesh_detail {

std::optional<std::pair<double, int>> keep_energy(Material& m, const Rgb& brightest_colour) {
    Eigen::Index channel = 0;
    double most = (m.albedo * brightest_colour + m.specular).maxCoeff(&channel);
    // A texture's brightest texels count too (the albedo of a patch on them is theirs)
    // where they reflect more than they receive: a texel of 255, albedo 1, is white
    // paper in a photograph, and a patch is all of it rarely; a texture all of it is
    // caught by its mean above.
    if (m.texture) {
        Eigen::Index at = 0;
        const double texel = (m.tint * m.texture->image->brightest * brightest_colour + m.specular).maxCoeff(&at);
        if (texel > 1.0 && texel > most) most = texel, channel = at;
    }
    if (most < 1.0) return std::nullopt;
    m.albedo *= 0.99 / most;
    m.tint *= 0.99 / most;
    m.specular *= 0.99 / most;
    return std::pair{most, static_cast<int>(channel)};
}

}  // namespace mesh_detail

std::string material_setting(const std::string& name) {
    return name.find_first_of(".[]\"") == std::string::npos ? "materials." + name : "materials[\"" + name + "\"]";
}

std::vector<int> mesh_materials(Scene& scene, std::size_t scene_materials, const MeshData& data, const std::string& path,
                                const std::string& shown, const std::string& where, const MaterialEdits& edits) {
    // PLY and OFF name no materials: the object gives its own.
    if (data.materials.empty() && data.material_defs.empty()) {
        const std::string ext = mesh_detail::lower_extension(path);
        if (ext != "obj") throw SceneError(shown, where, "has no \"material\", and a ." + ext + " file names none");
    }
    // The scene file's own material of a name: it replaces the mesh's.
    const auto own = [&](const std::string& name) {
        const int m = scene.find_material(name);
        return m >= 0 && static_cast<std::size_t>(m) < scene_materials ? m : -1;
    };
    const auto placed = [](int added) { return added >= 0 ? added : -1 - added; };
    // A mesh's warning once, however many times the mesh is placed.
    const auto warn = [&scene](const std::string& line) {
        if (std::find(scene.warnings.begin(), scene.warnings.end(), line) == scene.warnings.end())
            scene.warnings.push_back(line);
    };
    // The scene's index for a material the mesh brings: the brought one with the values
    // -D gives it, the scene's own of its name, an earlier mesh's of the same values, or
    // the brought one added (`fresh`: its warnings are news).
    struct Brought {
        int index;
        bool fresh;
    };
    const auto bring = [&](const Material& brought) -> Brought {
        if (const int mine = own(brought.name); mine >= 0) return {mine, false};
        Material m = brought;
        if (edits) edits(m);
        const int added = add_brought(scene, scene_materials, m, shown, where);
        const int at = placed(added);
        // Renamed "NAME (shown)" (another mesh's NAME differs): settings of that name.
        if (added >= 0 && edits && scene.materials[static_cast<std::size_t>(at)].name != brought.name) {
            Material& renamed = scene.materials[static_cast<std::size_t>(at)];
            edits(renamed);
        }
        return {at, added >= 0};
    };
    // A glTF file defines its materials itself (one per name, mapped by its reader); what
    // its reader said of a material the scene's own replaces is moot.
    if (!data.material_defs.empty()) {
        std::vector<int> index(data.materials.size());
        for (std::size_t k = 0; k < data.materials.size(); ++k) {
            const Brought b = bring(data.material_defs[k]);
            index[k] = b.index;
            if (!b.fresh && own(data.material_defs[k].name) >= 0) {
                const std::string about = shown + ": material '" + data.material_defs[k].name + "'";
                auto& w = scene.warnings;
                w.erase(std::remove_if(w.begin(), w.end(),
                                       [&](const std::string& line) { return line.compare(0, about.size(), about) == 0; }),
                        w.end());
            }
        }
        std::vector<int> out(data.triangles.size());
        for (std::size_t t = 0; t < out.size(); ++t) out[t] = index[static_cast<std::size_t>(data.triangle_material[t])];
        return out;
    }
    // The MTL files, relative to the mesh's folder; the first definition of a name counts.
    // A file that is not there (an asset copied without it, or named by a folder of the
    // exporter's machine and not beside the mesh either) is a warning, as in Blender: its
    // materials are then defined nowhere, and 0.8 grey.
    struct Defined {
        MtlMaterial material;
        std::string shown, folder;  // its file as shown, and the folder of its textures
    };
    std::map<std::string, Defined> defined;
    std::vector<std::string> missing;
    for (const auto& lib : data.material_libraries) {
        std::string file = in_folder(folder_of(path), lib), file_shown = in_folder(folder_of(shown), lib);
        std::error_code ec;
        if (!std::filesystem::exists(file, ec)) {
            const std::string base = lib.substr(lib.find_last_of('/') + 1);
            const std::string beside = in_folder(folder_of(path), base);
            if (base.empty() || beside == file || !std::filesystem::is_regular_file(beside, ec)) {
                missing.push_back(lib);
                continue;
            }
            file = beside;
            file_shown = in_folder(folder_of(shown), base);
        }
        scene.files.push_back(file);
        const std::string bytes = read_input_file(file, file_shown, "material file", kMaxSceneFileBytes);
        for (auto& m : parse_mtl(bytes, file_shown)) defined.emplace(m.name, Defined{m, file_shown, folder_of(file)});
    }
    for (const auto& lib : missing)
        warn(shown + ": mtllib " + lib + ": no such file" +
             (lib.find('/') != std::string::npos ? ", nor one of its name beside the mesh" : "") +
             "; the materials it would define are 0.8 grey");
    // A material of no values: the MTL's defaults, 0.8 grey, as Blender shows it.
    const auto grey = [&](const std::string& name) {
        MtlMaterial m;
        m.name = name;
        return Defined{m, shown, folder_of(path)};
    };
    std::vector<int> index(data.materials.size());
    Decoded decoded;  // each texture file once
    std::vector<std::string> nowhere;  // names defined nowhere, as "'name' (line n)"
    std::string first_nowhere;         // its name in the scene
    const auto from_file = [&](const Defined& d) {
        // Read again where an earlier mesh brought the same, its warnings were given then.
        const std::size_t warnings = scene.warnings.size();
        const Brought b = bring(from_mtl(d.material, d.shown, d.folder, scene.warnings, scene.files, decoded));
        if (!b.fresh) scene.warnings.resize(warnings);  // (its texture stays among the files read)
        return b.index;
    };
    for (std::size_t k = 0; k < data.materials.size(); ++k) {
        const std::string& name = data.materials[k];
        // The scene file's own material of that name comes first.
        if (const int m = own(name); m >= 0) {
            index[k] = m;
            continue;
        }
        auto it = defined.find(name);
        const bool found = it != defined.end();
        if (!found) it = defined.emplace(name, grey(name)).first;
        index[k] = from_file(it->second);
        if (!found) {
            nowhere.push_back("'" + name + "'" +
                              (k < data.material_lines.size() ? " (line " + std::to_string(data.material_lines[k]) + ")"
                                                             : std::string()));
            if (first_nowhere.empty()) first_nowhere = scene.materials[static_cast<std::size_t>(index[k])].name;
        }
    }
    if (!nowhere.empty() && !first_nowhere.empty()) {
        std::string libs, names;
        for (const auto& lib : data.material_libraries) libs += (libs.empty() ? "" : ", ") + lib;
        constexpr std::size_t kShown = 4;
        for (std::size_t k = 0; k < std::min(nowhere.size(), kShown); ++k) names += (k ? ", " : "") + nowhere[k];
        if (nowhere.size() > kShown) names += " and " + std::to_string(nowhere.size() - kShown) + " more";
        warn(shown + ": usemtl " + names + ": defined in no material file (" +
             (libs.empty() ? "the mesh has no mtllib" : "mtllib " + libs) + ") and not in the scene's \"materials\", so 0.8 grey; -D '" +
             material_setting(first_nowhere) + "={\"albedo\": [r, g, b]}' or the scene's \"materials\" defines one");
    }
    // Faces before the first usemtl, or an OBJ with none (Blender writes an object without
    // a material so): the material "default" (its MTL's where one defines it; else 0.8
    // grey, as Blender shows them).
    std::size_t before = 0;
    for (std::size_t t = 0; t < data.triangles.size(); ++t)
        before += t >= data.triangle_material.size() || data.triangle_material[t] < 0;
    int unnamed = -1;
    if (before > 0) {
        if (const int m = own("default"); m >= 0) {
            unnamed = m;
        } else {
            auto it = defined.find("default");
            if (it != defined.end() && std::any_of(nowhere.begin(), nowhere.end(), [](const std::string& n) {
                    return n.rfind("'default'", 0) == 0;
                }))
                it = defined.end();  // a usemtl default no MTL defines: grey, as the faces before it
            unnamed = from_file(it != defined.end() ? it->second : grey("default"));
            const std::string what = before == data.triangles.size()
                                         ? "its faces name no material (no usemtl)"
                                         : std::to_string(before) + (before == 1 ? " face comes" : " faces come") +
                                               " before the first usemtl";
            const std::string& name = scene.materials[static_cast<std::size_t>(unnamed)].name;
            warn(shown + ": " + what + ": material '" + name + "'" + (it != defined.end() ? "" : ", 0.8 grey") +
                 " (the scene's \"materials\" or -D '" + material_setting(name) + "={...}' defines it)");
        }
    }
    std::vector<int> out(data.triangles.size());
    for (std::size_t t = 0; t < out.size(); ++t) {
        const int m = t < data.triangle_material.size() ? data.triangle_material[t] : -1;
        out[t] = m < 0 ? unnamed : index[static_cast<std::size_t>(m)];
    }
    return out;
}

}  // namespace raybundle::scenes
