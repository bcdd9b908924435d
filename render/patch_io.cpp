#include "render/patch_io.h"

#include "render/image_io.h"

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <stdexcept>

namespace raybundle::render {

namespace {
std::ofstream open_output(const std::string& tmp, const std::string& shown, std::ios::openmode mode) {
    std::ofstream out(tmp, mode);
    if (!out) throw std::runtime_error(shown + ": cannot open for writing");
    return out;
}
void finish(std::ofstream& out, const std::string& shown) {
    out.close();
    if (!out) throw std::runtime_error(shown + ": write failed");
}
}  // namespace

void write_patch_csv(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field) {
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out = open_output(tmp, path, std::ios::out);
        out << "id,cx,cy,cz,nx,ny,nz,area,r,g,b\n" << std::setprecision(9);
        const auto& patches = scene.patch_list();
        for (std::size_t i = 0; i < patches.size(); ++i) {
            const auto& p = patches[i];
            const auto& L = field.radiance[i];
            out << i << ',' << p.centroid.x() << ',' << p.centroid.y() << ',' << p.centroid.z() << ','
                << p.normal.x() << ',' << p.normal.y() << ',' << p.normal.z() << ',' << p.area << ',' << L[0]
                << ',' << L[1] << ',' << L[2] << '\n';
        }
        finish(out, path);
    });
}

void write_patch_ply(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field,
                     double exposure) {
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out = open_output(tmp, path, std::ios::out | std::ios::binary);
        const auto& patches = scene.patch_list();
        const auto& pos = scene.vertex_positions();
        out << "ply\nformat binary_little_endian 1.0\ncomment raybundle per-patch radiance\n"
            << "element vertex " << 3 * patches.size() << "\nproperty float x\nproperty float y\nproperty float z\n"
            << "element face " << patches.size() << "\nproperty list uchar int vertex_indices\n"
            << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            << "property float radiance_r\nproperty float radiance_g\nproperty float radiance_b\nend_header\n";
        auto put = [&](const auto& value) { out.write(reinterpret_cast<const char*>(&value), sizeof(value)); };
        for (const auto& p : patches)
            for (int v : p.v)
                for (int k = 0; k < 3; ++k) put(static_cast<float>(pos[v][k]));
        for (std::size_t i = 0; i < patches.size(); ++i) {
            put(static_cast<unsigned char>(3));
            for (int k = 0; k < 3; ++k) put(static_cast<int>(3 * i + k));
            for (int k = 0; k < 3; ++k) put(tone_map(field.radiance[i][k], exposure));
            for (int k = 0; k < 3; ++k) put(static_cast<float>(field.radiance[i][k]));
        }
        finish(out, path);
    });
}

bool is_baked_asset(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext == ".glb";
}

void write_patch_glb(const std::string& path, const scenes::Scene& scene, const solver::RadianceField& field,
                     double exposure) {
    using nlohmann::json;
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const std::size_t n = 3 * patches.size();  // vertices
    // The binary chunk: positions, normals, colours, radiance, each n x 3 floats.
    constexpr int kAttributes = 4;
    std::vector<float> data(kAttributes * 3 * n);
    float* positions = data.data();
    float* normals = positions + 3 * n;
    float* colours = normals + 3 * n;
    float* radiance = colours + 3 * n;
    const double gain = std::exp2(exposure);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
    for (std::size_t i = 0; i < patches.size(); ++i) {
        const auto& p = patches[i];
        const Eigen::Vector3f normal = p.normal.cast<float>().normalized();
        for (std::size_t k = 0; k < 3; ++k) {
            const std::size_t v = 3 * i + k;
            const Eigen::Vector3f x = pos[p.v[k]].cast<float>();
            lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
            for (int c = 0; c < 3; ++c) {
                positions[3 * v + c] = x[c];
                normals[3 * v + c] = normal[c];
                colours[3 * v + c] = static_cast<float>(std::min(1.0, gain * field.radiance[i][c]));
                radiance[3 * v + c] = static_cast<float>(field.radiance[i][c]);
            }
        }
    }
    const std::size_t view_bytes = 3 * n * sizeof(float);
    json views = json::array(), accessors = json::array();
    for (int a = 0; a < kAttributes; ++a) {
        views.push_back({{"buffer", 0}, {"byteOffset", a * view_bytes}, {"byteLength", view_bytes}, {"target", 34962}});
        accessors.push_back({{"bufferView", a}, {"componentType", 5126}, {"count", n}, {"type", "VEC3"}});
    }
    accessors[0]["min"] = {lo.x(), lo.y(), lo.z()};
    accessors[0]["max"] = {hi.x(), hi.y(), hi.z()};
    // The scene's camera, for viewers that open the asset through it.
    const auto& cam = scene.camera;
    const Eigen::Vector3d back = (cam.eye - cam.target).normalized(), right = cam.up.cross(back).normalized();
    Eigen::Matrix3d basis;
    basis << right, back.cross(right), back;
    const Eigen::Quaterniond q(basis);
    const json doc = {
        {"asset",
         {{"version", "2.0"},
          {"generator", "raybundle"},
          {"extras",
           {{"exposure", exposure},
            {"colour", "COLOR_0 is min(1, 2^exposure * L), linear, with L the patch's radiance (as the PNG before its "
                       "sRGB curve); _RADIANCE is L itself"}}}}},
        {"extensionsUsed", {"KHR_materials_unlit"}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0, 1}}}}},
        {"nodes",
         {{{"name", "radiance"}, {"mesh", 0}},
          {{"name", "camera"},
           {"camera", 0},
           {"translation", {cam.eye.x(), cam.eye.y(), cam.eye.z()}},
           {"rotation", {q.x(), q.y(), q.z(), q.w()}}}}},
        {"cameras",
         {{{"type", "perspective"},
           {"perspective",
            {{"yfov", cam.fov_y * M_PI / 180.0},
             {"aspectRatio", static_cast<double>(cam.width) / cam.height},
             {"znear", 1e-3 * std::max(1e-6, static_cast<double>((hi - lo).norm()))}}}}}},
        {"meshes",
         {{{"name", "radiance"},
           {"primitives",
            {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"COLOR_0", 2}, {"_RADIANCE", 3}}}, {"material", 0}, {"mode", 4}}}}}}},
        {"materials",
         {{{"name", "radiance"},
           {"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}}, {"metallicFactor", 0.0}}},
           {"extensions", {{"KHR_materials_unlit", json::object()}}}}}},
        {"buffers", {{{"byteLength", data.size() * sizeof(float)}}}},
        {"bufferViews", views},
        {"accessors", accessors}};
    std::string text = doc.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    const std::size_t bin = data.size() * sizeof(float);  // a multiple of 4
    const std::uint64_t total = 12 + 8 + text.size() + 8 + bin;
    if (total > 0xffffffffull)
        throw std::runtime_error(path + ": " + std::to_string(patches.size()) + " patches exceed a GLB's 4 GiB");
    write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out = open_output(tmp, path, std::ios::out | std::ios::binary);
        auto put = [&](std::uint32_t word) { out.write(reinterpret_cast<const char*>(&word), 4); };
        put(0x46546C67u);  // "glTF"
        put(2);
        put(static_cast<std::uint32_t>(total));
        put(static_cast<std::uint32_t>(text.size()));
        put(0x4E4F534Au);  // "JSON"
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
        put(static_cast<std::uint32_t>(bin));
        put(0x004E4942u);  // "BIN"
        out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(bin));
        finish(out, path);
    });
}

}  // namespace raybundle::render
