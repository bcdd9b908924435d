// The piecewise-linear basis (004 section 5.3) against the constant basis and
// against exact radiance at vertices.
#include "reference.h"
#include "render/shade.h"
#include "scenes/builtin.h"
#include "solver/linear_basis.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <vector>

using namespace raybundle;
using namespace raybundle::testing;

namespace {

solver::RadianceField solve(const scenes::Scene& scene, bool linear, long steps, std::uint64_t seed) {
    const solver::Transport transport(scene);
    solver::SolverOptions opt;
    sampling::RunOptions opt_run;
    opt.steps = steps;
    opt_run.seed = seed;
    if (linear) {
        solver::LinearIteration it(transport, opt, opt_run);
        it.run();
        return it.field();
    }
    auto backend = visibility::make_backend("painter", scene, {});
    solver::StochasticIteration it(transport, *backend, opt, opt_run);
    it.run();
    return it.field();
}

// A vertex strictly inside one wall of the unit box (one coordinate 0 or 1).
bool inside_a_wall(const Vec3& p) {
    int on = 0, inside = 0;
    for (int k = 0; k < 3; ++k) {
        if (std::abs(p[k]) < 1e-9 || std::abs(p[k] - 1.0) < 1e-9) ++on;
        if (p[k] > 1e-9 && p[k] < 1.0 - 1e-9) ++inside;
    }
    return on == 1 && inside == 2;
}

}  // namespace

TEST_CASE("linear basis: the homogeneous box stays at 1", "[solver][linear]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    const auto field = solve(scene, true, 2000, 1);
    CHECK(field.mean_radiance(scene) == Approx(1.0).epsilon(0.01));
    CHECK(field.relative_l1_error(scene, 1.0) < 0.03);
    REQUIRE(field.corners.size() == scene.patch_count());
}

TEST_CASE("linear basis: the six-albedo box agrees with the constant basis, and is closer at wall vertices",
          "[solver][linear]") {
    const auto scene = six_albedo_box(0.5);
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();

    // Exact radiance at the coarse mesh's wall vertices: a fine radiosity solution,
    // gathered at the vertex with exact point-to-triangle form factors.
    const auto fine = six_albedo_box(0.2);
    const auto B = radiosity(fine, form_factors(fine, 3));
    std::map<int, Rgb> exact;  // vertex -> radiance
    for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const int v = patches[i].v[k];
            const Vec3 x = scene.vertex_positions()[v];
            if (!inside_a_wall(x) || exact.count(v)) continue;
            Rgb gathered = Rgb::Zero();
            for (std::size_t j = 0; j < fine.patch_count(); ++j)
                if (fine.patch_list()[j].normal.dot(patches[i].normal) < 0.999)
                    gathered += point_to_triangle(x, patches[i].normal, triangle_of(fine, j)) * B[j];
            exact[v] = scene.material_of(i).emission + scene.material_of(i).albedo * gathered;
        }
    REQUIRE(exact.size() >= 12);

    // Both bases, averaged over seeds so that noise stays below the differences.
    const int K = 4;
    const long steps = 4000;
    std::vector<Rgb> patch_c(n, Rgb::Zero()), patch_l(n, Rgb::Zero());
    std::map<int, Rgb> vertex_c, vertex_l;
    for (int s = 0; s < K; ++s) {
        const auto c = solve(scene, false, steps, 10 + s), l = solve(scene, true, steps, 10 + s);
        const auto corners_c = render::corner_radiance(scene, c);  // the smooth image's vertex values
        for (std::size_t i = 0; i < n; ++i) {
            patch_c[i] += c.radiance[i] / K;
            patch_l[i] += l.radiance[i] / K;
        }
        // Every patch around an interior wall vertex gives the same corner value: take
        // the first.
        std::map<int, bool> done;
        for (std::size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) {
                const int v = patches[i].v[k];
                if (!exact.count(v) || done[v]) continue;
                done[v] = true;
                if (!vertex_c.count(v)) vertex_c[v] = vertex_l[v] = Rgb::Zero();
                vertex_c[v] += corners_c[i][k] / K;
                vertex_l[v] += l.corners[i][k] / K;
            }
    }
    // Patch means: the same solution within discretisation error.
    double diff = 0.0, ref = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        diff += patches[i].area * (patch_l[i] - patch_c[i]).abs().sum();
        ref += patches[i].area * patch_c[i].sum();
    }
    INFO("patches " << n << ", relative L1 difference linear vs constant: " << diff / ref);
    CHECK(diff / ref < 0.03);

    // At wall vertices: relative L1 error against the exact radiance.
    double err_c = 0.0, err_l = 0.0, norm = 0.0;
    for (const auto& [v, L] : exact) {
        err_c += (vertex_c[v] - L).abs().sum();
        err_l += (vertex_l[v] - L).abs().sum();
        norm += L.sum();
    }
    // Measured (4 seeds x 4000 steps, 96 patches, seeds 10, 100, 200, 300): constant
    // 0.0109 0.0069 0.0095 0.0095; linear 0.0088 0.0051 0.0068 0.0066.
    INFO(exact.size() << " wall vertices: constant basis " << err_c / norm << ", linear basis " << err_l / norm);
    CHECK(err_l < err_c);
    CHECK(err_l / norm < 0.03);
}

TEST_CASE("linear basis: glossy scenes are refused with a message", "[solver][linear]") {
    auto scene = testing::glossy_box(0.5);
    const solver::Transport transport(scene);
    CHECK_THROWS_WITH(solver::LinearIteration(transport, {}, {}), Catch::Contains("diffuse scenes only"));
}
