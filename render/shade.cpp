#include "render/shade.h"

#include "scenes/threads.h"

#include <cmath>
#include <stdexcept>

namespace raybundle::render {

using scenes::Rgb;

Shading parse_shading(const std::string& name) {
    for (std::size_t k = 0; k < kShadingNames.size(); ++k)
        if (name == kShadingNames[k]) return static_cast<Shading>(k);
    throw std::invalid_argument("unknown shading '" + name + "' (known: flat, smooth)");
}

const char* shading_name(Shading s) { return kShadingNames[static_cast<std::size_t>(s)]; }

Buffer<std::array<Rgb, 3>> corner_radiance(const scenes::Scene& scene, const solver::RadianceField& field,
                                           int threads) {
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();
    const scenes::VertexCorners star = scenes::vertex_corners(scene);

    const auto& normals = scene.corner_normals();
    const double same = std::cos(1.0 * M_PI / 180.0);
    Buffer<std::array<Rgb, 3>> corners(n);
    parallel_bands(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i)
            for (int k = 0; k < 3; ++k) {
                const int v = patches[i].v[k];
                Rgb sum = Rgb::Zero();
                double weight = 0.0;
                for (std::size_t e = star.start[v]; e < star.start[v + 1]; ++e) {
                    const std::uint32_t j = star.corners[e] / 3;
                    const auto& q = patches[j];
                    if (q.material != patches[i].material || normals[j][star.corners[e] % 3].dot(normals[i][k]) < same)
                        continue;
                    sum += q.area * field.radiance[j];
                    weight += q.area;
                }
                corners[i][k] = sum / weight;  // weight > 0: patch i itself always qualifies
            }
    });
    return corners;
}

Image shade(const scenes::Scene& scene, const solver::RadianceField& field, const GBuffer& g, Shading mode,
            int threads) {
    Image img(g.width, g.height, Image::Unfilled{});  // every pixel written below
    // The linear basis has its own corner values; the constant basis averages patches
    // (read where they are, not copied).
    Buffer<std::array<Rgb, 3>> averaged;
    if (mode == Shading::Smooth && field.corners.empty()) averaged = corner_radiance(scene, field, threads);
    const auto& corners = field.corners.empty() ? averaged : field.corners;
    parallel_bands(g.height, threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < g.width; ++x) {
                const GSample& s = g.at(x, y);
                Rgb L;
                if (!s.front && s.patch >= 0) {
                    L = Rgb::Zero();  // a patch seen from behind: black
                } else if (s.patch < 0) {
                    L = background(scene, s.direction);
                } else if (mode == Shading::Flat) {
                    L = field.radiance[s.patch];
                } else {
                    const auto& c = corners[s.patch];
                    L = (1.0 - s.b1 - s.b2) * c[0] + s.b1 * c[1] + s.b2 * c[2];
                }
                float* px = img.at(x, y);
                for (int k = 0; k < 3; ++k) px[k] = static_cast<float>(L[k]);
            }
    });
    return img;
}

}  // namespace raybundle::render
