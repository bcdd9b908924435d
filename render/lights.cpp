#include "render/lights.h"

#include "solver/form_factor.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;

namespace {

// Lambert's sum over the edges of a polygon given relative to the receiver (vertices
// counter-clockwise about the front normal, which faces the receiver), all on or
// above the receiver's plane.
double edge_term(const Vec3& n, const Vec3& p, const Vec3& q) {
    const double lp = p.norm(), lq = q.norm();
    if (lp <= 0.0 || lq <= 0.0) return 0.0;
    const Vec3 u = p / lp, v = q / lq;
    const Vec3 c = v.cross(u);
    const double s = c.norm();
    if (s <= 0.0) return 0.0;
    const double beta = std::atan2(s, u.dot(v));
    return 0.5 * beta * n.dot(c) / s;
}

}  // namespace

AreaLights::AreaLights(const scenes::Scene& scene) : scene_(scene), patches_(scene.patch_list()) {
    auto corners_of = [&](std::uint32_t j) {
        const auto& pos = scene.vertex_positions();
        return std::array<Vec3, 3>{pos[patches_[j].v[0]], pos[patches_[j].v[1]], pos[patches_[j].v[2]]};
    };
    double total = 0.0;
    power_.assign(patches_.size(), 0.0);
    // Lights: emissive patches of one object and material on one plane.
    std::map<std::tuple<int, int, long, long, long, long>, std::size_t> index;
    const double scale = 1e6, plane_scale = 1e6 / std::max(scene.bounds_radius(), 1e-300);
    for (std::size_t j = 0; j < patches_.size(); ++j) {
        const auto& m = scene.material_of(j);
        const double power = patches_[j].area * m.emission.mean();
        if (!(power > 0.0)) continue;
        total += power;
        power_[j] = power;
        emitters_.push_back(static_cast<std::uint32_t>(j));
        cdf_.values.push_back(total);
        const auto& p = patches_[j];
        const double offset = p.normal.dot(scene.vertex_positions()[p.v[0]]);
        const auto key = std::make_tuple(p.object, p.material, std::lround(p.normal.x() * scale),
                                         std::lround(p.normal.y() * scale), std::lround(p.normal.z() * scale),
                                         std::lround(offset * plane_scale));
        auto [it, added] = index.emplace(key, lights_.size());
        if (added) lights_.push_back({m.emission, p.normal, offset, {}, {}, {}, {}});
        lights_[it->second].patches.push_back(static_cast<std::uint32_t>(j));
    }
    if (total > 0.0) {
        for (auto& c : cdf_.values) c /= total;
        for (auto& p : power_) p /= total;
    }
    // Each light's outline: the directed edges whose reverse is not an edge of it, those
    // that run straight on joined (scenes/scene.h).
    for (auto& light : lights_) {
        const auto& pos = scene.vertex_positions();
        for (const auto& [from, to] : scenes::plane_outline(scene, light.patches)) light.outline.push_back({pos[from], pos[to]});
        for (auto j : light.patches) {
            light.area += patches_[j].area;
            light.area_cdf.values.push_back(light.area);
            light.corners.push_back(corners_of(j));
        }
        for (auto& c : light.area_cdf.values) c /= light.area;
        light.area_cdf.finish();
    }
    for (const std::uint32_t j : emitters_) corners_.push_back(corners_of(j));
    cdf_.finish();
}

void AreaLights::Cdf::finish() {
    const std::size_t n = values.size();
    guide.resize(n + 1);
    for (std::size_t c = 0; c <= n; ++c)
        guide[c] = static_cast<std::uint32_t>(
            std::upper_bound(values.begin(), values.end(), static_cast<double>(c) / static_cast<double>(n)) -
            values.begin());
}

std::size_t AreaLights::Cdf::index(double u) const {
    const std::size_t n = values.size();
    // u's cell, give or take one for the rounding of u n against c / n.
    const double at = u * static_cast<double>(n);
    const std::size_t c = at > 0.0 ? std::min(static_cast<std::size_t>(at), n - 1) : 0;
    const auto first = values.begin() + guide[c > 0 ? c - 1 : 0], last = values.begin() + guide[std::min(c + 2, n)];
    return std::min(static_cast<std::size_t>(std::upper_bound(first, last, u) - values.begin()), n - 1);
}

AreaLights::Sample AreaLights::sample(double pick, double u1, double u2) const {
    const std::size_t e = cdf_.index(pick);
    const auto& p = corners_[e];
    const double r1 = std::sqrt(u1);
    return {emitters_[e], (1.0 - r1) * p[0] + r1 * (1.0 - u2) * p[1] + r1 * u2 * p[2]};
}

double AreaLights::projected_solid_angle(const Vec3& x, const Vec3& n, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 front = (b - a).cross(c - a);
    if (front.dot(x - a) <= 0.0) return 0.0;  // x behind the triangle or in its plane
    // Clip the triangle (relative to x) to the half-space above x's plane.
    const std::array<Vec3, 3> in = {a - x, b - x, c - x};
    std::array<Vec3, 4> out;
    int m = 0;
    for (int i = 0; i < 3; ++i) {
        const Vec3& p = in[i];
        const Vec3& q = in[(i + 1) % 3];
        const double dp = n.dot(p), dq = n.dot(q);
        if (dp >= 0.0) out[m++] = p;
        if ((dp >= 0.0) != (dq >= 0.0)) out[m++] = p + (dp / (dp - dq)) * (q - p);
    }
    double omega = 0.0;
    for (int i = 0; i < m; ++i) omega += edge_term(n, out[i], out[(i + 1) % m]);
    return std::max(0.0, omega);
}

AreaLights::Sample AreaLights::sample_light(std::size_t l, double pick, double u1, double u2) const {
    const Light& light = lights_[l];
    const std::size_t k = light.area_cdf.index(pick);
    const auto& p = light.corners[k];
    const double r1 = std::sqrt(u1);
    return {light.patches[k], (1.0 - r1) * p[0] + r1 * (1.0 - u2) * p[1] + r1 * u2 * p[2]};
}

Rgb AreaLights::irradiance(const Vec3& x, const Vec3& n) const {
    Rgb e = Rgb::Zero();
    for (std::size_t l = 0; l < lights_.size(); ++l) e += irradiance(l, x, n);
    return e;
}

Rgb AreaLights::irradiance(std::size_t l, const Vec3& x, const Vec3& n) const {
    const Light& light = lights_[l];
    // Behind the light, or in its plane (within 1e-9 of the scene: a point of the light
    // itself, which rounding puts on either side, would see the whole outline around it,
    // and the outline's clipping needs a point off the plane).
    if (light.normal.dot(x) - light.offset <= 1e-9 * scene_.bounds_radius()) return Rgb::Zero();
    // The projected solid angle is pi times the form factor to the light's part in front
    // of x's plane: its outline clipped to that plane (solver/form_factor.h, as the
    // diffuse shot's groups of emitters).
    return light.emission * (M_PI * solver::point_to_outline(x, n, light.outline));
}

}  // namespace raybundle::render
