// A closed box with a different albedo on every wall against an independent answer:
// a deterministic radiosity solve whose patch-to-patch form factors come from
// Lambert's exact point-to-polygon formula integrated over the receiving patch.
#include "scenes/builtin.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <vector>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;

namespace {

// Form factor from a differential area at x (normal n) to a triangle (Lambert).
double point_to_triangle(const Vec3& x, const Vec3& n, const std::array<Vec3, 3>& tri) {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) {
        const Vec3 a = (tri[k] - x).normalized(), b = (tri[(k + 1) % 3] - x).normalized();
        const Vec3 c = a.cross(b);
        const double len = c.norm();
        if (len < 1e-15) continue;
        sum += std::atan2(len, a.dot(b)) * n.dot(c / len);
    }
    return std::abs(sum) / (2.0 * M_PI);
}

// Mean of f over a triangle: centroid rule on 4^levels congruent sub-triangles.
template <class F>
double triangle_mean(const std::array<Vec3, 3>& t, int levels, F&& f) {
    if (levels == 0) return f((t[0] + t[1] + t[2]) / 3.0);
    const Vec3 m01 = 0.5 * (t[0] + t[1]), m12 = 0.5 * (t[1] + t[2]), m20 = 0.5 * (t[2] + t[0]);
    return 0.25 * (triangle_mean({t[0], m01, m20}, levels - 1, f) + triangle_mean({m01, t[1], m12}, levels - 1, f) +
                   triangle_mean({m20, m12, t[2]}, levels - 1, f) + triangle_mean({m01, m12, m20}, levels - 1, f));
}

}  // namespace

TEST_CASE("closed box with different wall albedos agrees with a deterministic radiosity solve",
          "[solver][reference]") {
    auto scene = scenes::make_builtin("homogeneous-box", 0.5);
    // One material per wall, chosen by the patch's normal; only the ceiling emits.
    scene.materials.clear();
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
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();

    // Reference: form factors, then L = Le + rho F L by Jacobi iteration.
    std::vector<std::array<Vec3, 3>> tris(n);
    for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) tris[i][k] = scene.vertex_positions()[patches[i].v[k]];
    std::vector<double> F(n * n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            if (i == j || patches[i].normal.dot(patches[j].normal) > 0.999) continue;  // coplanar: 0
            F[i * n + j] = triangle_mean(tris[i], 4, [&](const Vec3& x) {
                return point_to_triangle(x, patches[i].normal, tris[j]);
            });
        }
    for (std::size_t i = 0; i < n; ++i) {
        double row = 0.0;
        for (std::size_t j = 0; j < n; ++j) row += F[i * n + j];
        REQUIRE(row == Approx(1.0).epsilon(2e-3));  // closed box: the form factors sum to 1
    }
    std::vector<Rgb> ref(n, Rgb::Zero()), next(n);
    for (int sweep = 0; sweep < 200; ++sweep) {
        for (std::size_t i = 0; i < n; ++i) {
            Rgb gathered = Rgb::Zero();
            for (std::size_t j = 0; j < n; ++j) gathered += F[i * n + j] * ref[j];
            next[i] = scene.material_of(i).emission + scene.material_of(i).albedo * gathered;
        }
        ref.swap(next);
    }

    // Ray-bundle stochastic iteration, K independent seeds: mean and standard error.
    const int K = 16;
    std::vector<Rgb> sum(n, Rgb::Zero()), sum2(n, Rgb::Zero());
    for (int k = 0; k < K; ++k) {
        auto backend = visibility::make_backend("painter", scene, {});
        solver::IterationOptions opt;
        opt.iterations = 1500;
        opt.seed = 1000 + k;
        solver::StochasticIteration it(scene, *backend, opt);
        it.run();
        const auto field = it.field();
        for (std::size_t i = 0; i < n; ++i) {
            sum[i] += field.radiance[i];
            sum2[i] += field.radiance[i].square();
        }
    }
    double chi2 = 0.0, worst = 0.0, l1 = 0.0, l1_ref = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const Rgb mean = sum[i] / K;
        const Rgb var = (sum2[i] / K - mean.square()) * (static_cast<double>(K) / (K - 1));
        const Rgb se = (var / K).sqrt();
        const Rgb z = (mean - ref[i]) / se;
        chi2 += z.square().sum();
        worst = std::max(worst, z.abs().maxCoeff());
        l1 += patches[i].area * (mean - ref[i]).abs().sum();
        l1_ref += patches[i].area * ref[i].sum();
    }
    chi2 /= 3.0 * n;
    INFO("patches " << n << ", mean z^2 " << chi2 << ", worst |z| " << worst << ", relative L1 " << l1 / l1_ref);
    CHECK(chi2 < 2.0);     // unbiased: E[z^2] = (K-1)/(K-3) = 1.15 for Student's t with 15 dof
    CHECK(worst < 6.0);
    CHECK(l1 / l1_ref < 0.01);
}
