#include "solver/first_shot.h"

#include <algorithm>
#include <cmath>

namespace raybundle::solver {

using scenes::Rgb;
using scenes::Vec3;

FirstShot first_shot(const scenes::Scene& scene, const scenes::RayCaster& caster) {
    FirstShot shot;
    const std::size_t n = scene.patch_count();
    shot.irradiance.assign(n, Rgb::Zero());
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const double eps = 1e-9 * scene.bounds_radius();
    for (const auto& light : scene.point_lights) {
        for (std::size_t i = 0; i < n; ++i) {
            const auto& p = patches[i];
            const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
            const Vec3 to_centre = p.centroid - light.position;
            // The light must be in front of the patch's plane (emission and reception
            // are one-sided); a light on the plane gives nothing.
            if (p.normal.dot(light.position - a) <= 0.0) continue;
            const double edge = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
            const double dist = std::max(to_centre.norm(), eps);
            const int N = std::clamp(static_cast<int>(std::ceil(8.0 * edge / dist)), 2, 64);
            double sum = 0.0;
            auto sample = [&](double u, double v) {
                const Vec3 x = a + u * (b - a) + v * (c - a);
                const Vec3 d = x - light.position;
                const double r = d.norm();
                const double cos_theta = -p.normal.dot(d) / r;
                if (cos_theta <= 0.0) return;
                ++shot.shadow_rays;
                // Blocked if anything lies between the light and x (x's own patch is at r).
                const auto hit = caster.intersect(light.position, d / r, 0.0, r * (1.0 - 1e-5));
                if (hit.valid()) return;
                sum += cos_theta / (r * r);
            };
            // Centroids of the N^2 sub-triangles: "upright" (i + j < N) and "inverted"
            // (i + j < N - 1), all of area A / N^2.
            for (int s = 0; s < N; ++s)
                for (int t = 0; s + t < N; ++t) {
                    sample((s + 1.0 / 3.0) / N, (t + 1.0 / 3.0) / N);
                    if (s + t < N - 1) sample((s + 2.0 / 3.0) / N, (t + 2.0 / 3.0) / N);
                }
            const Rgb e = light.intensity * (sum / (static_cast<double>(N) * N));
            if ((e == 0.0).all()) continue;
            shot.irradiance[i] += e;
            if (scene.material_of(i).glossy()) shot.glossy_hits.push_back({static_cast<std::uint32_t>(i), to_centre / dist, e});
        }
    }
    return shot;
}

}  // namespace raybundle::solver
