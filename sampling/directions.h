#pragma once
// Direction samplers on the unit sphere.
//
// Call order: construct with a seed, then next() once per global direction.
#include "sampling/rng.h"

#include <Eigen/Core>

#include <cmath>
#include <cstdint>

namespace raybundle::sampling {

// Maps (u1, u2) in [0,1)^2 to the unit sphere with uniform density 1/(4 pi).
inline Eigen::Vector3d uniform_sphere(double u1, double u2) {
    const double z = 1.0 - 2.0 * u1;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = 2.0 * M_PI * u2;
    return {r * std::cos(phi), r * std::sin(phi), z};
}

// Builds an orthonormal basis (u, v) perpendicular to the unit vector n
// (Duff et al., "Building an orthonormal basis, revisited", 2017).
inline void orthonormal_basis(const Eigen::Vector3d& n, Eigen::Vector3d& u, Eigen::Vector3d& v) {
    const double sign = std::copysign(1.0, n.z());
    const double a = -1.0 / (sign + n.z());
    const double b = n.x() * n.y() * a;
    u = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
    v = Eigen::Vector3d(b, sign + n.y() * n.y() * a, -n.y());
}

// Independent uniform random directions: the sampler stochastic iteration needs
// (its proof, 004 section 4.4, asks for independent consecutive directions).
class RandomDirections {
public:
    explicit RandomDirections(std::uint64_t seed) : rng_(seed, /*stream=*/0x5eed) {}
    Eigen::Vector3d next() {
        const double u1 = rng_.uniform();
        const double u2 = rng_.uniform();
        return uniform_sphere(u1, u2);
    }

private:
    Rng rng_;
};

}  // namespace raybundle::sampling
