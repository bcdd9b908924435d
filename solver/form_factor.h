#pragma once
// Lambert's closed form for the form factor from a differential area to a polygon:
// F = 1/(2 pi) sum_k angle_k (n . unit normal of the plane through x and edge k).
#include "scenes/scene.h"

#include <array>
#include <cmath>

namespace raybundle::solver {

// One edge p -> q of a polygon's outline in Lambert's formula for the form factor from
// a differential area at x with unit normal n: the angle the edge subtends at x times
// n's component along the normal of the plane through x and the edge. The form factor
// is |sum over the outline| / 2 pi; an edge shared by two polygons of one plane cancels.
inline double lambert_edge(const scenes::Vec3& x, const scenes::Vec3& n, const scenes::Vec3& p, const scenes::Vec3& q) {
    const scenes::Vec3 a = (p - x).normalized(), b = (q - x).normalized();
    const scenes::Vec3 c = a.cross(b);
    const double len = c.norm();
    return len < 1e-15 ? 0.0 : std::atan2(len, a.dot(b)) * n.dot(c / len);
}

// Form factor from a differential area at x with unit normal n to the triangle tri
// (unoccluded; the part of tri behind x's plane must be empty, as between the walls
// of a convex room).
inline double point_to_triangle(const scenes::Vec3& x, const scenes::Vec3& n, const std::array<scenes::Vec3, 3>& tri) {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) sum += lambert_edge(x, n, tri[k], tri[(k + 1) % 3]);
    return std::abs(sum) / (2.0 * M_PI);
}

}  // namespace raybundle::solver
