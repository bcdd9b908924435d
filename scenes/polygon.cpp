#include "scenes/mesh_file.h"

#include "scenes/errors.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace raybundle::scenes {

namespace {

// Twice the signed area of the 2-D triangle (a, b, c): positive counter-clockwise.
double turn(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
    return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

// Whether the closed segments ab and cd meet.
bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                   const Eigen::Vector2d& d, double eps) {
    const double d1 = turn(a, b, c), d2 = turn(a, b, d), d3 = turn(c, d, a), d4 = turn(c, d, b);
    if (((d1 > eps && d2 < -eps) || (d1 < -eps && d2 > eps)) && ((d3 > eps && d4 < -eps) || (d3 < -eps && d4 > eps)))
        return true;
    // Touching: an end on the other segment.
    auto on = [eps](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, double t) {
        return std::abs(t) <= eps && r.x() >= std::min(p.x(), q.x()) - 1e-12 && r.x() <= std::max(p.x(), q.x()) + 1e-12 &&
               r.y() >= std::min(p.y(), q.y()) - 1e-12 && r.y() <= std::max(p.y(), q.y()) + 1e-12;
    };
    return on(a, b, c, d1) || on(a, b, d, d2) || on(c, d, a, d3) || on(c, d, b, d4);
}

}  // namespace

std::vector<std::array<int, 3>> triangulate_polygon(const std::vector<Vec3>& corners, double max_bend,
                                                    const std::string& shown, const std::string& where) {
    std::vector<std::array<int, 3>> fan;
    for (int k = 1; k + 1 < static_cast<int>(corners.size()); ++k) fan.push_back({0, k, k + 1});
    if (corners.size() <= 3) return fan;
    // A corner repeated next to itself adds nothing: the rest is cut, and the indices
    // mapped back. Repeated to rounding too (within 1e-9 of the polygon's size: a UV
    // sphere's pole written at full precision, sin(pi) = 1.2e-16 off).
    Vec3 lo = corners.front(), hi = lo;
    for (const auto& c : corners) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    const double same = 1e-9 * (hi - lo).norm();
    const auto repeat = [&](int a, int b) { return (corners[a] - corners[b]).norm() <= same; };
    std::vector<int> index;
    for (int i = 0; i < static_cast<int>(corners.size()); ++i)
        if (index.empty() || !repeat(i, index.back())) index.push_back(i);
    while (index.size() > 1 && repeat(index.back(), index.front())) index.pop_back();
    if (index.size() < 3) return fan;  // zero area: dropped on load
    // Relative to the first corner: the normal's cross products then cancel nothing
    // of a large offset (a 3 m quad at x = 1e9 has a normal of 18, not of rounding).
    std::vector<Vec3> p;
    for (int i : index) p.push_back(corners[i] - corners[index.front()]);
    auto original = [&](std::vector<std::array<int, 3>> t) {
        for (auto& tri : t)
            for (int& k : tri) k = index[k];
        return t;
    };
    const int n = static_cast<int>(p.size());
    if (n == 3) return original({{0, 1, 2}});
    fan.clear();
    for (int k = 1; k + 1 < n; ++k) fan.push_back({0, k, k + 1});
    // Newell's normal (twice the vector area), the longest edge, the mean plane.
    Vec3 normal = Vec3::Zero(), mean = Vec3::Zero();
    double longest = 0.0;
    for (int i = 0; i < n; ++i) {
        const Vec3& a = p[i];
        const Vec3& b = p[(i + 1) % n];
        normal += a.cross(b);
        longest = std::max(longest, (b - a).norm());
        mean += a / n;
    }
    const double size = normal.norm();
    if (!(size > 1e-12 * longest * longest)) {
        // No area in all: a polygon on a line (its triangles dropped on load), or one
        // whose parts cancel (a symmetric bow tie), which crosses itself.
        for (const auto& t : fan)
            if ((p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm() > 1e-9 * longest * longest)
                throw SceneError(shown, where,
                                 "a polygon of " + std::to_string(corners.size()) +
                                     " corners crosses itself (its parts' areas cancel)");
        return original(fan);
    }
    const Vec3 u = normal / size;
    int worst = 0;
    double bend = 0.0;
    for (int i = 0; i < n; ++i) {
        const double off = std::abs(u.dot(p[i] - mean));
        if (off > bend) bend = off, worst = index[i];
    }
    if (bend > max_bend * longest) {
        // Off a plane, every corner of a quad lies as far: name the one whose others share
        // an x, y or z (a hand-typed floor with one corner raised), where one does.
        int lone = -1;
        double lone_off = 0.0;
        for (int i = 0; i < n && lone != -2; ++i)
            for (int axis = 0; axis < 3; ++axis) {
                const double at = corners[index[(i + 1) % n]][axis];
                bool shared = true;
                for (int j = 0; j < n && shared; ++j) shared = j == i || corners[index[j]][axis] == at;
                if (shared && corners[index[i]][axis] != at) {
                    lone = lone == -1 ? index[i] : -2;  // two such corners: no one to name
                    lone_off = std::abs(corners[index[i]][axis] - at);
                    break;
                }
            }
        std::ostringstream why;
        why << "a polygon of " << corners.size() << " corners is not planar: corner ";
        if (lone >= 0)
            why << lone << " lies " << lone_off << " off the plane of the others";
        else
            why << worst << " lies " << bend << " off its plane";
        why << ", more than " << max_bend << " of its longest edge (" << longest << ")";
        throw SceneError(shown, where, why.str());
    }
    // In the plane, counter-clockwise (u is the polygon's own normal).
    const Vec3 ax = (std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(u).normalized();
    const Vec3 ay = u.cross(ax);
    std::vector<Eigen::Vector2d> q;
    for (const auto& x : p) q.emplace_back(ax.dot(x - mean), ay.dot(x - mean));
    const double eps = 1e-12 * longest * longest;
    for (int i = 0; i < n; ++i)
        for (int j = i + 2; j < n; ++j) {
            if (i == 0 && j == n - 1) continue;  // neighbours
            if (segments_meet(q[i], q[(i + 1) % n], q[j], q[(j + 1) % n], eps))
                throw SceneError(shown, where,
                                 "a polygon of " + std::to_string(corners.size()) +
                                     " corners crosses or touches itself (its edges from corners " + std::to_string(index[i]) +
                                     " and " + std::to_string(index[j]) + " meet)");
        }
    // A convex polygon is a fan, unless a corner is straight (on the line of its
    // neighbours, as modellers leave a vertex on an edge): a fan from or across it would
    // make a zero-area triangle, which ear clipping does not (an ear's tip turns).
    bool convex = true, straight = false;
    for (int i = 0; i < n && convex; ++i) {
        const double t = turn(q[(i + n - 1) % n], q[i], q[(i + 1) % n]);
        convex = t >= -eps;
        straight = straight || t <= eps;
    }
    if (convex && !straight) return original(fan);
    // Ear clipping: a corner that turns left and whose triangle holds no other corner.
    std::vector<int> left(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) left[i] = i;
    std::vector<std::array<int, 3>> out;
    while (left.size() > 3) {
        const int m = static_cast<int>(left.size());
        int ear = -1;
        for (int k = 0; k < m && ear < 0; ++k) {
            const int a = left[(k + m - 1) % m], b = left[k], c = left[(k + 1) % m];
            if (turn(q[a], q[b], q[c]) <= eps) continue;
            bool empty = true;
            for (int r : left) {
                if (r == a || r == b || r == c) continue;
                if (turn(q[a], q[b], q[r]) >= -eps && turn(q[b], q[c], q[r]) >= -eps && turn(q[c], q[a], q[r]) >= -eps) {
                    empty = false;
                    break;
                }
            }
            if (empty) ear = k;
        }
        if (ear < 0) ear = 0;  // only straight corners left: a zero-area triangle
        out.push_back({left[(ear + m - 1) % m], left[ear], left[(ear + 1) % m]});
        left.erase(left.begin() + ear);
    }
    out.push_back({left[0], left[1], left[2]});
    return original(out);
}

}  // namespace raybundle::scenes
