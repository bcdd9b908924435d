#pragma once
// Lambert's closed form for the form factor from a differential area to a polygon:
// F = 1/(2 pi) sum_k angle_k (n . unit normal of the plane through x and edge k).
#include "scenes/scene.h"

#include <array>
#include <cmath>

namespace raybundle::solver {

// Form factor from a differential area at x with unit normal n to the triangle tri
// (unoccluded; the part of tri behind x's plane must be empty, as between the walls
// of a convex room).
inline double point_to_triangle(const scenes::Vec3& x, const scenes::Vec3& n, const std::array<scenes::Vec3, 3>& tri) {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) {
        const scenes::Vec3 a = (tri[k] - x).normalized(), b = (tri[(k + 1) % 3] - x).normalized();
        const scenes::Vec3 c = a.cross(b);
        const double len = c.norm();
        if (len < 1e-15) continue;
        sum += std::atan2(len, a.dot(b)) * n.dot(c / len);
    }
    return std::abs(sum) / (2.0 * M_PI);
}

}  // namespace raybundle::solver
