#pragma once
// A local frame around a unit vector: the geometry that visibility maps, BRDFs and
// hemisphere samplers share.
#include <Eigen/Core>

#include <cmath>

namespace raybundle::scenes {

// Builds an orthonormal basis (u, v) perpendicular to the unit vector n, right-handed
// with n (Duff et al., "Building an orthonormal basis, revisited", 2017).
inline void orthonormal_basis(const Eigen::Vector3d& n, Eigen::Vector3d& u, Eigen::Vector3d& v) {
    const double sign = std::copysign(1.0, n.z());
    const double a = -1.0 / (sign + n.z());
    const double b = n.x() * n.y() * a;
    u = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
    v = Eigen::Vector3d(b, sign + n.y() * n.y() * a, -n.y());
}

}  // namespace raybundle::scenes
