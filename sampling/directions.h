#pragma once
// Direction samplers on the unit sphere.
//
// Call order: construct with a seed, then next() once per global direction.
#include "sampling/rng.h"
#include "sampling/streams.h"

#include <Eigen/Core>

#include <algorithm>
#include <array>
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

// Maps (u1, u2) in [0,1)^2 to a direction around the unit normal n with density
// cos(theta) / pi (Malley's method), given an orthonormal basis (u, v) of n's plane (scenes/frame.h).
inline Eigen::Vector3d cosine_hemisphere(double u1, double u2, const Eigen::Vector3d& n, const Eigen::Vector3d& u,
                                         const Eigen::Vector3d& v) {
    const double r = std::sqrt(u1), phi = 2.0 * M_PI * u2;
    return r * std::cos(phi) * u + r * std::sin(phi) * v + std::sqrt(std::max(0.0, 1.0 - u1)) * n;
}

// Independent uniform random directions: the sampler stochastic iteration needs
// (its proof, 004 section 4.4, asks for independent consecutive directions).
class RandomDirections {
public:
    explicit RandomDirections(std::uint64_t seed, std::uint64_t chain = 0) : rng_(seed, streams::kDirections[chain]) {}
    Eigen::Vector3d next() {
        const double u1 = rng_.uniform();
        const double u2 = rng_.uniform();
        return uniform_sphere(u1, u2);
    }
    // A uniformly random orthonormal frame (a random rotation's axes): the first axis
    // uniform on the sphere, the second uniform on its great circle, the third their
    // cross product; each axis alone is uniform on the sphere.
    std::array<Eigen::Vector3d, 3> next_frame() {
        const Eigen::Vector3d a = next();
        const Eigen::Vector3d u =
            (std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(a).normalized();
        const Eigen::Vector3d v = a.cross(u);
        const double phi = 2.0 * M_PI * rng_.uniform();
        const Eigen::Vector3d b = std::cos(phi) * u + std::sin(phi) * v;
        return {a, b, a.cross(b)};
    }
    // Its generator, to save and restore (checkpoints).
    Rng& generator() { return rng_; }
    const Rng& generator() const { return rng_; }

private:
    Rng rng_;
};

}  // namespace raybundle::sampling
