#pragma once
// Integrands of known value on [0,1)^4 for the VEGAS tests: two "directions", each a
// point (u, v) of the unit square, as sampling::VegasTables sees a walk of two.
#include <cmath>

namespace raybundle::test {

// A peak per direction: g(u, v) = exp(-((u - 0.3)^2 + (v - 0.6)^2) / (2 s^2)),
// f = g(z0, z1) g(z2, z3). Separable along every axis; its integral is the product of
// four one-dimensional Gaussian integrals over [0, 1].
constexpr double kPeakWidth = 0.06;
inline double peak(const double* z) {
    auto g = [](double u, double v) {
        return std::exp(-((u - 0.3) * (u - 0.3) + (v - 0.6) * (v - 0.6)) / (2 * kPeakWidth * kPeakWidth));
    };
    return g(z[0], z[1]) * g(z[2], z[3]);
}
inline double peak_integral() {
    auto one = [](double c) {
        const double s = kPeakWidth;
        return s * std::sqrt(M_PI / 2.0) * (std::erf((1.0 - c) / (s * std::sqrt(2.0))) + std::erf(c / (s * std::sqrt(2.0))));
    };
    return one(0.3) * one(0.6) * one(0.3) * one(0.6);
}

// A ridge per direction: r(u, v) = exp(-(u - v)^2 / (2 s^2)), f = r(z0, z1) r(z2, z3).
// Each axis's marginal is nearly flat: the mass lies along the square's diagonal, as a
// cone of directions couples theta and phi. The integral of r over the square is
// the integral over t = u - v of (1 - |t|) exp(-t^2 / (2 s^2)):
// 2 (s sqrt(pi/2) erf(1 / (s sqrt 2)) - s^2 (1 - exp(-1 / (2 s^2)))).
constexpr double kRidgeWidth = 0.03;
inline double ridge(const double* z) {
    auto r = [](double u, double v) { return std::exp(-(u - v) * (u - v) / (2 * kRidgeWidth * kRidgeWidth)); };
    return r(z[0], z[1]) * r(z[2], z[3]);
}
inline double ridge_integral() {
    const double s = kRidgeWidth;
    const double one = 2.0 * (s * std::sqrt(M_PI / 2.0) * std::erf(1.0 / (s * std::sqrt(2.0))) -
                              s * s * (1.0 - std::exp(-1.0 / (2.0 * s * s))));
    return one * one;
}

}  // namespace raybundle::test
