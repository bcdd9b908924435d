// Dammertz et al.'s edge-avoiding À-Trous filter (render/filters.h).
#include "render/edge_filter.h"
#include "render/filter_support.h"
#include "render/filters.h"
#include "scenes/threads.h"

#include <string>
#include <utility>

namespace raybundle::render {

using namespace detail;

Image atrous_filter(const Image& input, const Guide& guide, int iterations, double sigma_colour,
                    double sigma_normal, double sigma_position, int threads) {
    const char* fn = "atrous_filter";
    if (iterations < 1 || iterations > 16) fail(fn, "iterations " + std::to_string(iterations) + " not in [1, 16]");
    check_edge_filter(fn, input, guide, threads, {1, 3, 4, 6}, "{1, 3, 4, 6}",
                      {{"sigma_colour", sigma_colour}, {"sigma_normal", sigma_normal}, {"sigma_position", sigma_position}});

    EdgeFilter f(input, guide);
    static constexpr float kB3[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    const float kn = static_cast<float>(-1.0 / (sigma_normal * sigma_normal));
    const float kx = static_cast<float>(-1.0 / (sigma_position * sigma_position));
    for (int it = 0; it < iterations; ++it) {
        const int step = 1 << it;
        const double sc = sigma_colour / step;
        const float kc = static_cast<float>(-1.0 / (sc * sc));
        parallel_bands(f.h, threads, [&](int y0, int y1) {
            EdgeFilter::Row row(f.w);
            for (int y = y0; y < y1; ++y) {
                row.clear();
                for (int j = 0; j < 5; ++j)
                    for (int i = 0; i < 5; ++i)
                        f.add_tap(row, f.colour.data(), y, (i - 2) * step, (j - 2) * step, 0.0f, kB3[j] * kB3[i], kc,
                                  kn, kx);
                f.store_row(row, y, f.result.data());
            }
        });
        std::swap(f.colour, f.result);
    }
    return f.interleaved(f.colour);
}

}  // namespace raybundle::render
