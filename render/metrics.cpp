#include "render/metrics.h"

#include <cmath>
#include <stdexcept>

namespace raybundle::render {

namespace {
void check(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) throw std::invalid_argument("image sizes differ");
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

}  // namespace raybundle::render
