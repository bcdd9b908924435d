#include "render/patch_io.h"

#include "render/image_io.h"

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

}  // namespace raybundle::render
