#include "render/metrics.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace raybundle::render {

namespace {

void check(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height)
        throw std::invalid_argument("image sizes differ: " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                                    " and " + std::to_string(b.width) + "x" + std::to_string(b.height));
}

// each(sums of a, sums of b) per whole k x k block, per channel.
template <class Each>
void for_blocks(const Image& a, const Image& b, int k, Each each) {
    check(a, b);
    if (k < 1) throw std::invalid_argument("block size must be >= 1, got " + std::to_string(k));
    for (int by = 0; by + k <= a.height; by += k)
        for (int bx = 0; bx + k <= a.width; bx += k) {
            std::array<double, 3> sa{}, sb{};
            for (int y = by; y < by + k; ++y)
                for (int x = bx; x < bx + k; ++x)
                    for (int c = 0; c < 3; ++c) {
                        sa[c] += a.at(x, y)[c];
                        sb[c] += b.at(x, y)[c];
                    }
            each(sa, sb);
        }
}

}  // namespace

double relative_l1(const Image& a, const Image& reference) {
    check(a, reference);
    double err = 0.0, ref = 0.0;
    for (std::size_t k = 0; k < a.rgb.size(); ++k) {
        err += std::abs(static_cast<double>(a.rgb[k]) - reference.rgb[k]);
        ref += std::abs(static_cast<double>(reference.rgb[k]));
    }
    return ref > 0 ? err / ref : err;
}

double mse(const Image& a, const Image& reference) {
    check(a, reference);
    double err = 0.0;
    for (std::size_t k = 0; k < a.rgb.size(); ++k) {
        const double d = static_cast<double>(a.rgb[k]) - reference.rgb[k];
        err += d * d;
    }
    return a.rgb.empty() ? 0.0 : err / static_cast<double>(a.rgb.size());
}

double block_relative_l1(const Image& a, const Image& reference, int k) {
    double err = 0.0, ref = 0.0;
    for_blocks(a, reference, k, [&](const std::array<double, 3>& sa, const std::array<double, 3>& sb) {
        for (int c = 0; c < 3; ++c) {
            err += std::abs(sa[c] - sb[c]);
            ref += std::abs(sb[c]);
        }
    });
    return ref > 0 ? err / ref : err;
}

std::vector<double> block_errors(const Image& a, const Image& reference, int k) {
    std::vector<double> errors;
    for_blocks(a, reference, k, [&](const std::array<double, 3>& sa, const std::array<double, 3>& sb) {
        const double ref = sb[0] + sb[1] + sb[2];
        errors.push_back(ref != 0.0 ? (sa[0] + sa[1] + sa[2] - ref) / ref : 0.0);
    });
    return errors;
}

double worst_block(const Image& a, const Image& reference, int k) {
    double worst = 0.0;
    for (const double e : block_errors(a, reference, k))
        if (std::abs(e) > std::abs(worst)) worst = e;
    return worst;
}

ImageError image_error(const Image& a, const Image& reference) {
    return {relative_l1(a, reference), mse(a, reference), block_relative_l1(a, reference, 4),
            worst_block(a, reference, 16)};
}

}  // namespace raybundle::render
