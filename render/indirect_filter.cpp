// The choice of filter for the final gather's indirect light, and the guide it gets.
#include "render/filters.h"

#include <algorithm>
#include <cmath>
#include "scenes/errors.h"
#include "scenes/threads.h"

namespace raybundle::render {

using scenes::Vec3;

Filter parse_filter(const std::string& name) {
    std::string known;
    for (std::size_t k = 0; k < kFilterNames.size(); ++k) {
        if (name == kFilterNames[k]) return static_cast<Filter>(k);
        known += (k > 0 ? ", " : "") + std::string(kFilterNames[k]);
    }
    throw scenes::OptionError("filter", "unknown filter '" + name + "' (known: " + known + ")");
}

const char* filter_name(Filter f) { return kFilterNames[static_cast<std::size_t>(f)]; }

int auto_filter_radius(int width, int height, int gather_rays) {
    const double size = std::max(width, height) / 256.0;
    const double r = 3.0 * size * std::pow(32.0 / std::max(gather_rays, 1), 0.25);
    return std::clamp(static_cast<int>(std::lround(r)), 1, kMaxGuidedRadius);
}

Image filter_indirect(const Image& indirect, const Image& normal, const Image& depth, const Image& position,
                      const Vec3& origin, double depth_scale, double position_scale, const FilterOptions& o,
                      int threads) {
    if (o.filter == Filter::none) return indirect;
    if (o.filter == Filter::atrous) {
        Guide guide(indirect.width, indirect.height, 6);
        parallel_bands(indirect.height, threads, [&](int y0, int y1) {
            for (int y = y0; y < y1; ++y)
                for (int x = 0; x < indirect.width; ++x) {
                    float* g = guide.at(x, y);
                    const float* n = normal.at(x, y);
                    const float* p = position.at(x, y);
                    const bool hit = n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f;  // background: all zero
                    for (int k = 0; k < 3; ++k) {
                        g[k] = n[k];
                        g[3 + k] = hit ? static_cast<float>((p[k] - origin[k]) * position_scale) : 0.0f;
                    }
                }
        });
        return atrous_filter(indirect, guide, o.atrous_iterations, o.sigma_colour, o.sigma_normal, o.sigma_depth,
                             threads);
    }
    Guide guide(indirect.width, indirect.height, 4);
    parallel_bands(indirect.height, threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < indirect.width; ++x) {
                float* g = guide.at(x, y);
                const float* n = normal.at(x, y);
                g[0] = n[0];
                g[1] = n[1];
                g[2] = n[2];
                g[3] = static_cast<float>(depth.at(x, y)[0] * depth_scale);
            }
    });
    switch (o.filter) {
        case Filter::guided:
            return guided_filter(indirect, guide, o.radius, {o.eps_normal, o.eps_normal, o.eps_normal, o.eps_depth},
                                 threads);
        case Filter::bilateral:
            return cross_bilateral_filter(indirect, guide, o.radius, o.sigma_spatial, o.sigma_normal, o.sigma_depth,
                                          threads);
        case Filter::atrous:
        case Filter::none: break;
    }
    return indirect;
}

}  // namespace raybundle::render
