// A closed box with a different albedo on every wall against an independent answer:
// a deterministic radiosity solve whose patch-to-patch form factors come from
// Lambert's exact point-to-polygon formula integrated over the receiving patch.
#include "reference.h"
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

using namespace raybundle::testing;

TEST_CASE("closed box with different wall albedos agrees with a deterministic radiosity solve",
          "[solver][reference]") {
    const auto scene = six_albedo_box(0.5);
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();

    // Reference: form factors, then L = Le + rho F L by Jacobi iteration.
    const std::vector<double> F = form_factors(scene, 4);
    for (std::size_t i = 0; i < n; ++i) {
        double row = 0.0;
        for (std::size_t j = 0; j < n; ++j) row += F[i * n + j];
        REQUIRE(row == Approx(1.0).epsilon(2e-3));  // closed box: the form factors sum to 1
    }
    const std::vector<Rgb> ref = radiosity(scene, F);

    // Ray-bundle stochastic iteration, K independent seeds: mean and standard error.
    const int K = 16;
    std::vector<Rgb> sum(n, Rgb::Zero()), sum2(n, Rgb::Zero());
    for (int k = 0; k < K; ++k) {
        auto backend = visibility::make_backend("painter", scene, {});
        solver::SolverOptions opt;
        sampling::RunOptions opt_run;
        opt.steps = 1500;
        opt_run.seed = 1000 + k;
        solver::StochasticIteration it(scene, *backend, opt, opt_run);
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
