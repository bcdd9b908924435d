#include "scenes/errors.h"
#include "scenes/mesh_file.h"
#include "scenes/mesh_readers.h"

#include <cstdio>  // before jpeglib.h, which uses FILE and size_t

#include <jpeglib.h>
#include <png.h>

#include <csetjmp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <vector>

namespace raybundle::scenes {

using mesh_detail::png_mean_colour;

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

// The mean linear colour of a PNG texture file, or nothing for a file that is missing or
// not a PNG it can read, with why in `why`.
std::optional<Rgb> texture_mean(const std::string& path, std::string& why) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
        why = "no such file";
        return std::nullopt;
    }
    if (!std::filesystem::is_regular_file(path, ec)) {
        why = "not a regular file";
        return std::nullopt;
    }
    try {
        return png_mean_colour(read_input_file(path, path, "texture", kMaxSceneFileBytes), &why);
    } catch (const SceneError& e) {
        why = e.problem();
        return std::nullopt;
    }
}

// A material of the scene from an MTL's: Kd the albedo, Ke the emission, Ks and Ns the
// Phong lobe where illum asks for highlights (not 0 or 1), scaled down where Kd + Ks
// reaches 1; a lobe of exponent 0 is Lambertian and joins the albedo, and Blender's Ks
// is no lobe (below). What is read otherwise or not at all is a warning.
Material from_mtl(const MtlMaterial& m, const std::string& file, const std::string& folder,
                  std::vector<std::string>& warnings, std::vector<std::string>& files) {
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
    // A texture is its mean colour (as a renderer showing it would average it over the
    // surface; the texture itself, not times Kd, as Blender's importer shows it).
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
        if (const auto mean = texture_mean(in_folder(folder, map), why)) {
            out.albedo = *mean;
            files.push_back(in_folder(folder, map));
            warnings.push_back(named + ": its texture " + map + " is read as its mean colour " + number((*mean)[0]) +
                               " " + number((*mean)[1]) + " " + number((*mean)[2]));
        } else {
            const bool relative = !map.empty() && map[0] != '/';
            warnings.push_back(named + ": its texture " + map + " is not read (" + why +
                               (why == "no such file" && relative ? " beside " + file : std::string()) + "); its Kd " +
                               number(m.kd[0]) + " " + number(m.kd[1]) + " " + number(m.kd[2]) + " is the colour");
        }
    }
    if (const auto sum = mesh_detail::keep_energy(out))
        warnings.push_back(named + ": Kd + Ks = " + number(sum->first) + " in channel " + "rgb"[sum->second] +
                           ": both scaled by " + number(0.99 / sum->first) + " (a surface reflects less than it receives)");
    return out;
}

bool same_values(const Material& a, const Material& b) {
    return (a.albedo == b.albedo).all() && (a.emission == b.emission).all() && (a.specular == b.specular).all() &&
           a.exponent == b.exponent && a.two_sided == b.two_sided;
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

std::optional<std::pair<double, int>> keep_energy(Material& m) {
    Eigen::Index channel = 0;
    const double most = (m.albedo + m.specular).maxCoeff(&channel);
    if (most < 1.0) return std::nullopt;
    m.albedo *= 0.99 / most;
    m.specular *= 0.99 / most;
    return std::pair{most, static_cast<int>(channel)};
}

namespace {

// sRGB's 8-bit values, decoded to linear.
struct SrgbTable {
    double linear[256];
    SrgbTable() {
        for (int v = 0; v < 256; ++v) {
            const double c = v / 255.0;
            linear[v] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
        }
    }
};
const SrgbTable kSrgb;

// libjpeg's errors end its calls by longjmp (a C library: no exception may cross it).
struct JpegErrors {
    jpeg_error_mgr manager;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

// Why a JPEG's header is refused, or "" (its size: at most 8k x 8k texels, as a PNG).
std::string jpeg_size_refused(const jpeg_decompress_struct& jpeg) {
    if (jpeg.image_width > 0 && jpeg.image_height > 0 && jpeg.image_width <= 8192 && jpeg.image_height <= 8192) return "";
    return "a JPEG of " + std::to_string(jpeg.image_width) + " x " + std::to_string(jpeg.image_height) +
           " texels, more than 8192 x 8192";
}

// Decodes a JPEG's texels into `sum` (linear, summed) and `texels`, or says why not in
// `why`. The setjmp of libjpeg's errors is here, with locals of trivial types only (as
// libjpeg's own example): what outlives a longjmp is the caller's.
bool decode_jpeg(std::string_view bytes, std::vector<JSAMPLE>& row, Rgb& sum, double& texels, std::string& why) {
    jpeg_decompress_struct jpeg{};
    JpegErrors errors{};
    jpeg.err = jpeg_std_error(&errors.manager);
    errors.manager.error_exit = [](j_common_ptr common) {
        auto* e = reinterpret_cast<JpegErrors*>(common->err);
        (*common->err->format_message)(common, e->message);
        std::longjmp(e->jump, 1);
    };
    errors.manager.output_message = [](j_common_ptr) {};  // its warnings: counted below
    if (setjmp(errors.jump)) {
        jpeg_destroy_decompress(&jpeg);
        why = std::string("a JPEG libjpeg cannot read: ") + errors.message;
        return false;
    }
    jpeg_create_decompress(&jpeg);
    jpeg_mem_src(&jpeg, reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<unsigned long>(bytes.size()));
    jpeg_read_header(&jpeg, TRUE);
    why = jpeg_size_refused(jpeg);
    if (!why.empty()) {
        jpeg_destroy_decompress(&jpeg);
        return false;
    }
    jpeg.out_color_space = JCS_RGB;  // grey and YCbCr alike (CMYK is refused: its message)
    jpeg_start_decompress(&jpeg);
    row.resize(static_cast<std::size_t>(jpeg.output_width) * 3);
    while (jpeg.output_scanline < jpeg.output_height) {
        JSAMPROW rows[1] = {row.data()};
        jpeg_read_scanlines(&jpeg, rows, 1);
        for (std::size_t i = 0; i + 2 < row.size(); i += 3)
            sum += Rgb(kSrgb.linear[row[i]], kSrgb.linear[row[i + 1]], kSrgb.linear[row[i + 2]]);
    }
    texels = static_cast<double>(jpeg.output_width) * jpeg.output_height;
    jpeg_finish_decompress(&jpeg);
    // A warning (a file cut short: libjpeg fills the rest with grey) leaves no mean of
    // the texture's own colours.
    const long warnings = jpeg.err->num_warnings;
    jpeg_destroy_decompress(&jpeg);
    if (warnings > 0) why = "a JPEG libjpeg reads only in part (cut short?)";
    return warnings == 0;
}

std::optional<Rgb> jpeg_mean_colour(std::string_view bytes, std::string* why) {
    std::vector<JSAMPLE> row;
    Rgb sum = Rgb::Zero();
    double texels = 0.0;
    std::string reason;
    if (!decode_jpeg(bytes, row, sum, texels, reason)) {
        if (why) *why = reason;
        return std::nullopt;
    }
    return Rgb(sum / texels);
}

}  // namespace

std::optional<Rgb> png_mean_colour(std::string_view bytes, std::string* why) {
    auto fail = [why](std::string reason) {
        if (why) *why = std::move(reason);
        return std::nullopt;
    };
    auto starts = [bytes](std::string_view magic) { return bytes.substr(0, magic.size()) == magic; };
    if (starts("\xFF\xD8\xFF")) return jpeg_mean_colour(bytes, why);
    if (!starts("\x89PNG\r\n\x1A\n")) return fail("not a PNG or JPEG");
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
        return fail(std::string("a PNG libpng cannot read: ") + image.message);
    // RGBA, its alpha then left out: libpng's RGB would mix the colour onto black. The
    // 8-bit sRGB formats are not premultiplied.
    image.format = PNG_FORMAT_RGBA;
    // At most 8k x 8k texels (256 MB): a larger header is not a texture to average.
    if (image.width == 0 || image.height == 0 || image.width > 8192 || image.height > 8192) {
        const std::string size = std::to_string(image.width) + " x " + std::to_string(image.height);
        png_image_free(&image);
        return fail("a PNG of " + size + " texels, more than 8192 x 8192");
    }
    std::vector<png_byte> texels(PNG_IMAGE_SIZE(image));
    if (!png_image_finish_read(&image, nullptr, texels.data(), 0, nullptr))
        return fail(std::string("a PNG libpng cannot read: ") + image.message);
    Rgb sum = Rgb::Zero();
    for (std::size_t i = 0; i + 3 < texels.size(); i += 4)
        sum += Rgb(kSrgb.linear[texels[i]], kSrgb.linear[texels[i + 1]], kSrgb.linear[texels[i + 2]]);
    return sum / (static_cast<double>(texels.size()) / 4.0);
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
    std::vector<std::string> nowhere;  // names defined nowhere, as "'name' (line n)"
    std::string first_nowhere;         // its name in the scene
    const auto from_file = [&](const Defined& d) {
        // Read again where an earlier mesh brought the same, its warnings were given then.
        const std::size_t warnings = scene.warnings.size();
        const Brought b = bring(from_mtl(d.material, d.shown, d.folder, scene.warnings, scene.files));
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
