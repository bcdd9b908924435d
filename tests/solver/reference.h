#pragma once
// Independent answers for the solver tests: Lambert's exact point-to-polygon form
// factor, a centroid-rule mean over triangles, the six-albedo box, and a
// deterministic radiosity solve of it.
#include "scenes/builtin.h"
#include "scenes/scene.h"
#include "solver/form_factor.h"

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace raybundle::testing {

using scenes::Rgb;
using scenes::Vec3;

// Lambert's point-to-triangle form factor (the solver's diffuse shot uses it too).
using solver::point_to_triangle;

// Mean of f over a triangle: centroid rule on 4^levels congruent sub-triangles.
template <class F>
double triangle_mean(const std::array<Vec3, 3>& t, int levels, F&& f) {
    if (levels == 0) return f((t[0] + t[1] + t[2]) / 3.0);
    const Vec3 m01 = 0.5 * (t[0] + t[1]), m12 = 0.5 * (t[1] + t[2]), m20 = 0.5 * (t[2] + t[0]);
    return 0.25 * (triangle_mean({t[0], m01, m20}, levels - 1, f) + triangle_mean({m01, t[1], m12}, levels - 1, f) +
                   triangle_mean({m20, m12, t[2]}, levels - 1, f) + triangle_mean({m01, m12, m20}, levels - 1, f));
}

inline std::array<Vec3, 3> triangle_of(const scenes::Scene& scene, std::size_t i) {
    const auto& p = scene.patch_list()[i];
    const auto& pos = scene.vertex_positions();
    return {pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]};
}

// The unit box with one material per wall (chosen by the wall's normal); only the
// ceiling (wall 3, normal -y) emits.
inline scenes::Scene six_albedo_box(double patch_size) {
    auto scene = scenes::make_builtin("homogeneous-box", patch_size);
    scene.materials.clear();
    scene.exact_radiance.reset();
    scene.homogeneous_albedo.reset();
    const Rgb albedo[6] = {{0.8, 0.2, 0.2}, {0.2, 0.8, 0.2}, {0.7, 0.7, 0.7},
                           {0.3, 0.3, 0.3}, {0.2, 0.2, 0.8}, {0.5, 0.6, 0.4}};
    for (int w = 0; w < 6; ++w) {
        scenes::Material m;
        m.name = "wall" + std::to_string(w);
        m.albedo = albedo[w];
        if (w == 3) m.emission = Rgb(1.0, 0.9, 0.8);
        scene.add_material(m);
    }
    auto wall_of = [](const Vec3& n) {
        const int axis = std::abs(n.x()) > 0.5 ? 0 : (std::abs(n.y()) > 0.5 ? 1 : 2);
        return 2 * axis + (n[axis] > 0 ? 0 : 1);
    };
    for (auto f : scene.mesh.faces()) {
        auto it = scene.mesh.cfv_iter(f);
        const Vec3 a = scenes::to_eigen(scene.mesh.point(*it++)), b = scenes::to_eigen(scene.mesh.point(*it++)),
                   c = scenes::to_eigen(scene.mesh.point(*it));
        scene.mesh.property(scene.material_handle, f) = wall_of((b - a).cross(c - a).normalized());
    }
    scene.finalize();
    return scene;
}

// The homogeneous box with half its albedo made glossy (modified Phong, exponent
// 10): the hemispherical albedo is at most 0.5 at every incidence.
inline scenes::Scene glossy_box(double patch_size) {
    auto scene = scenes::make_builtin("homogeneous-box", patch_size);
    scene.materials[0].albedo = Rgb::Constant(0.25);
    scene.materials[0].specular = Rgb::Constant(0.25);
    scene.materials[0].exponent = 10.0;
    return scene;
}

// Form factors F[i n + j] of a closed scene of planar walls (coplanar pairs: 0), by
// the centroid rule on 4^levels points over each receiver.
inline std::vector<double> form_factors(const scenes::Scene& scene, int levels) {
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();
    std::vector<std::array<Vec3, 3>> tris(n);
    for (std::size_t i = 0; i < n; ++i) tris[i] = triangle_of(scene, i);
    std::vector<double> F(n * n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            if (i == j || patches[i].normal.dot(patches[j].normal) > 0.999) continue;
            F[i * n + j] = triangle_mean(tris[i], levels, [&](const Vec3& x) {
                return point_to_triangle(x, patches[i].normal, tris[j]);
            });
        }
    return F;
}

// L = Le + rho F L by Jacobi iteration (the error after k sweeps falls like rho^k).
inline std::vector<Rgb> radiosity(const scenes::Scene& scene, const std::vector<double>& F, int sweeps = 200) {
    const std::size_t n = scene.patch_count();
    std::vector<Rgb> ref(n, Rgb::Zero()), next(n);
    for (int sweep = 0; sweep < sweeps; ++sweep) {
        for (std::size_t i = 0; i < n; ++i) {
            Rgb gathered = Rgb::Zero();
            for (std::size_t j = 0; j < n; ++j) gathered += F[i * n + j] * ref[j];
            next[i] = scene.material_of(i).emission + scene.material_of(i).albedo * gathered;
        }
        ref.swap(next);
    }
    return ref;
}

}  // namespace raybundle::testing
