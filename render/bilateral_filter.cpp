// The cross (joint) bilateral filter (render/filters.h).
#include "render/edge_filter.h"
#include "render/filter_support.h"
#include "render/filters.h"
#include "scenes/threads.h"

#include <string>
#include <utility>

namespace raybundle::render {

using namespace detail;

Image cross_bilateral_filter(const Image& input, const Guide& guide, int radius, double sigma_spatial,
                             double sigma_normal, double sigma_depth, int threads) {
    const char* fn = "cross_bilateral_filter";
    if (radius < 1) fail(fn, "radius " + std::to_string(radius) + " < 1");
    check_edge_filter(fn, input, guide, threads, {1, 3, 4}, "{1, 3, 4}",
                      {{"sigma_spatial", sigma_spatial}, {"sigma_normal", sigma_normal}, {"sigma_depth", sigma_depth}});

    EdgeFilter f(input, guide);
    const float kn = static_cast<float>(-0.5 / (sigma_normal * sigma_normal));
    const float kz = static_cast<float>(-0.5 / (sigma_depth * sigma_depth));
    const float ks = static_cast<float>(-0.5 / (sigma_spatial * sigma_spatial));
    parallel_bands(f.h, threads, [&](int y0, int y1) {
        EdgeFilter::Row row(f.w);
        for (int y = y0; y < y1; ++y) {
            row.clear();
            for (int dy = -radius; dy <= radius; ++dy)
                for (int dx = -radius; dx <= radius; ++dx)
                    f.add_tap(row, f.colour.data(), y, dx, dy, static_cast<float>(dx * dx + dy * dy) * ks, 1.0f, 0.0f,
                              kn, kz);
            f.store_row(row, y, f.result.data());
        }
    });
    return f.interleaved(f.result);
}

}  // namespace raybundle::render
