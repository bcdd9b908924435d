#pragma once
// What the cross bilateral and À-Trous filters share: four-lane float arithmetic, a
// fast exp of negative arguments, and the planar tap accumulator. Internal to render/.
#include "render/filters.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace raybundle::render::detail {

// Four floats at a time (one SSE2 operation); a float operand broadcasts.
using F4 = float __attribute__((vector_size(16)));
using I4 = std::int32_t __attribute__((vector_size(16)));
inline F4 load(const float* p) {
    F4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(float* p, F4 v) { std::memcpy(p, &v, sizeof v); }

// exp(x) for x <= 0: 2^n times a degree-6 Taylor polynomial of 2^f, |f| <= 1/2.
// Relative error below 7e-7 for x >= −8 and 4e-6 down to −87 (the float rounding of
// x·log2 e); below −87 it returns exp(−87) ≈ 1.6e-38, the smallest normal float.
inline F4 exp_negative(F4 x) {
    const F4 lo = F4{} - 87.0f;
    const F4 t = (x < lo ? lo : x) * 1.44269504f;
    const F4 n = (t + 12582912.0f) - 12582912.0f;  // 1.5·2^23: rounds to the nearest integer
    const F4 f = t - n;
    const F4 p = 1.0f + f * (0.693147181f +
                             f * (0.240226507f +
                                  f * (0.0555041087f + f * (0.00961812911f + f * (0.00133335581f + f * 0.000154035304f)))));
    const I4 bits = (__builtin_convertvector(n, I4) + 127) << 23;
    F4 scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

// Shared by the cross bilateral and À-Trous filters: planar copies of the guide and the
// colour, and the weighted sum of the taps at one offset for a whole row, four pixels
// at a time. Guide channels: [0, normals) the normal, [normals, channels) depth or
// position. Planes and rows carry 4 floats of padding for the last block's spare lanes.
struct EdgeFilter {
    int w, h, channels, normals;
    std::size_t pixels;
    std::vector<float> guide, colour, result;  // planar: channel c at [c * pixels]

    struct Row {  // the running sums of one output row
        std::size_t stride;
        std::vector<float> sum;  // 3 colour planes, then the weights
        explicit Row(int width) : stride(static_cast<std::size_t>(width) + 4), sum(4 * stride) {}
        void clear() { std::fill(sum.begin(), sum.end(), 0.0f); }
    };

    EdgeFilter(const Image& input, const Guide& g)
        : w(input.width), h(input.height), channels(g.channels), normals(g.channels >= 3 ? 3 : 0),
          pixels(static_cast<std::size_t>(w) * h), guide(pixels * channels + 4), colour(pixels * 3 + 4),
          result(pixels * 3 + 4) {
        for (std::size_t i = 0; i < pixels; ++i) {
            for (int c = 0; c < channels; ++c) guide[c * pixels + i] = g.data[i * channels + c];
            for (int c = 0; c < 3; ++c) colour[c * pixels + i] = input.rgb[i * 3 + c];
        }
    }

    // For every pixel x of row y whose tap (x+dx, y+dy) is inside the image, adds the tap
    // with weight  k · exp(e0 + kc·|Δcolour|² + kn·|Δnormal|² + kp·|Δdepth or position|²).
    void add_tap(Row& row, const float* col, int y, int dx, int dy, float e0, float k, float kc, float kn,
                 float kp) const {
        const int qy = y + dy;
        if (qy < 0 || qy >= h) return;
        const int x0 = std::max(0, -dx), x1 = std::min(w, w - dx);
        if (x0 >= x1) return;
        const bool c = kc != 0.0f;  // the bilateral filter has no colour term
        switch (channels) {
        case 1: c ? tap<0, 1, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<0, 1, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        case 3: c ? tap<3, 0, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<3, 0, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        case 4: c ? tap<3, 1, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<3, 1, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        default: c ? tap<3, 3, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                   : tap<3, 3, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        }
    }

    template <int Normals, int Positions, bool ColourTerm>
    void tap(Row& row, const float* col, int y, int qy, int dx, int x0, int x1, float e0, float k, float kc, float kn,
             float kp) const {
        const float* gp = guide.data() + static_cast<std::size_t>(y) * w;
        const float* gq = guide.data() + static_cast<std::size_t>(qy) * w + dx;
        const float* cp = col + static_cast<std::size_t>(y) * w;
        const float* cq = col + static_cast<std::size_t>(qy) * w + dx;
        float* s = row.sum.data();
        const std::size_t rs = row.stride;
        const I4 lane = {0, 1, 2, 3};
        for (int x = x0; x < x1; x += 4) {
            F4 dn = {}, dp = {}, dc = {};
            for (int c = 0; c < Normals; ++c) {
                const F4 d = load(gp + c * pixels + x) - load(gq + c * pixels + x);
                dn += d * d;
            }
            for (int c = Normals; c < Normals + Positions; ++c) {
                const F4 d = load(gp + c * pixels + x) - load(gq + c * pixels + x);
                dp += d * d;
            }
            if (ColourTerm)
                for (int c = 0; c < 3; ++c) {
                    const F4 d = load(cp + c * pixels + x) - load(cq + c * pixels + x);
                    dc += d * d;
                }
            F4 wt = k * exp_negative(e0 + kc * dc + kn * dn + kp * dp);
            wt = lane + x < x1 ? wt : F4{};  // the last block's lanes past x1 add nothing
            for (int c = 0; c < 3; ++c) store(s + c * rs + x, load(s + c * rs + x) + wt * load(cq + c * pixels + x));
            store(s + 3 * rs + x, load(s + 3 * rs + x) + wt);
        }
    }

    // out[·][y] = weighted sum / sum of weights (> 0: the centre tap is always there).
    void store_row(const Row& row, int y, float* out) const {
        const std::size_t p = static_cast<std::size_t>(y) * w;
        for (int c = 0; c < 3; ++c)
            for (int x = 0; x < w; ++x)
                out[c * pixels + p + x] = row.sum[c * row.stride + x] / row.sum[3 * row.stride + x];
    }

    Image interleaved(const std::vector<float>& planes) const {
        Image img(w, h);
        for (std::size_t i = 0; i < pixels; ++i)
            for (int c = 0; c < 3; ++c) img.rgb[i * 3 + c] = planes[c * pixels + i];
        return img;
    }
};

}  // namespace raybundle::render::detail
