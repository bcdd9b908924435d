#pragma once
// Lambert's closed form for the form factor from a differential area to a polygon:
// F = 1/(2 pi) sum_k angle_k (n . unit normal of the plane through x and edge k).
#include "scenes/scene.h"

#include <array>
#include <cmath>
#include <vector>

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

// Form factor from a differential area at x with unit normal n to the part in front of
// x's plane (n . (p - x) > 0) of a plane region, given by its outline: directed edges
// that form closed loops, all of one orientation as seen from x (the outline of
// coplanar triangles of one normal, x off their plane by more than rounding). Each edge's front part is
// summed, and the clipped region is closed along the line where the two planes meet:
// its closing edges run in x's plane, where edge e -> s adds the angle from e to s
// about n. They all lie on that line, which misses x, so every point's angle from one
// of them is within pi: the closing edges add up to the angles of the outline's
// returns to the front less those of its exits, however the points pair up. The
// triangles clipped one by one (point_to_triangle on each part in front) give the same.
inline double point_to_outline(const scenes::Vec3& x, const scenes::Vec3& n,
                               const std::vector<std::array<scenes::Vec3, 2>>& outline) {
    double sum = 0.0;
    scenes::Vec3 ref = scenes::Vec3::Zero();  // from x to the first crossing
    bool crossed = false;
    auto angle = [&](const scenes::Vec3& p) {  // of p - x from ref, about n
        const scenes::Vec3 r = p - x;
        return std::atan2(n.dot(ref.cross(r)), ref.dot(r));
    };
    for (const auto& [p, q] : outline) {
        const double dp = n.dot(p - x), dq = n.dot(q - x);
        const bool front_p = dp > 0.0, front_q = dq > 0.0;
        if (front_p && front_q) {
            sum += lambert_edge(x, n, p, q);
            continue;
        }
        if (front_p == front_q) continue;  // wholly behind, or on the plane
        const scenes::Vec3 cut = p + (dp / (dp - dq)) * (q - p);
        if (!crossed) ref = cut - x, crossed = true;
        if (front_p) {  // leaves the front: a closing edge starts at the cut
            sum += lambert_edge(x, n, p, cut);
            sum -= angle(cut);
        } else {  // comes back: a closing edge ends there
            sum += lambert_edge(x, n, cut, q);
            sum += angle(cut);
        }
    }
    return std::abs(sum) / (2.0 * M_PI);
}

}  // namespace raybundle::solver
