// Importance sampling of global walks (004 sections 7-8, sampling/adaptive.h,
// solver/global_walks.h): the Metropolis start-up bias against 004's formula and its
// removal by seeding, VEGAS on a peaked integrand of known value, and both samplers on
// the homogeneous box against random walks.
#include "sampling/adaptive.h"
#include "scenes/builtin.h"
#include "solver/global_walks.h"
#include "visibility/backend.h"
#include "tests/sampling/integrands.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <complex>
#include <vector>

using namespace raybundle;

namespace {

// The characteristic function of the perturbation of x = 2 pi (u - 1/2): uniform on
// [-pi delta, pi delta), P*(k) = sin(k pi delta) / (k pi delta) (004 eq. 42-43).
double characteristic(int k, double delta) {
    const double a = k * M_PI * delta;
    return std::sin(a) / a;
}

// N chains of a constant importance on the circle (every proposal accepted: 004
// section 8.4's case), n steps each, started at x = 0 (one seed) or at points picked
// from M uniform seeds in proportion to their (constant) importance (8.1.2). Returns
// the estimates of the Fourier coefficients c_k = E[exp(j k x_n)], k = 1..K.
std::vector<std::complex<double>> chains_after(int n, bool seeded, int N, int K, double delta) {
    const sampling::Mutation mutate{delta};
    sampling::Rng rng(5, 77);
    std::vector<double> seeds(512);
    for (double& s : seeds) s = rng.uniform();
    std::vector<std::complex<double>> c(static_cast<std::size_t>(K) + 1);
    for (int chain = 0; chain < N; ++chain) {
        double u = 0.5;
        if (seeded) {  // as the solver picks: a reservoir over the seeds (importance 1)
            sampling::Reservoir pick;
            for (double s : seeds)
                if (pick.offer(1.0, rng.uniform())) u = s;
        }
        for (int step = 0; step < n; ++step) {
            double next = 0.0;
            mutate(&u, &next, 1, rng);
            u = next;  // min(1, I(y) / I(x)) = 1
        }
        const double x = 2.0 * M_PI * (u - 0.5);
        for (int k = 1; k <= K; ++k) c[static_cast<std::size_t>(k)] += std::polar(1.0, k * x);
    }
    for (auto& v : c) v /= N;
    return c;
}

}  // namespace

TEST_CASE("Reservoir: one pass picks every item in proportion to its weight", "[sampling][metropolis]") {
    const std::vector<double> weights = {0.0, 1.0, 3.0, 0.0, 6.0};
    const int M = 100000;
    std::vector<int> picked(weights.size(), 0);
    sampling::Rng rng(9, 3);
    for (int m = 0; m < M; ++m) {
        sampling::Reservoir r;
        std::size_t pick = weights.size();
        for (std::size_t k = 0; k < weights.size(); ++k)
            if (r.offer(weights[k], rng.uniform())) pick = k;
        REQUIRE(pick < weights.size());
        ++picked[pick];
        CHECK(r.total == 10.0);
    }
    for (std::size_t k = 0; k < weights.size(); ++k) {
        const double p = weights[k] / 10.0;
        INFO("item " << k << ": " << picked[k] << " of " << M << ", expected share " << p);
        CHECK(std::abs(picked[k] - M * p) <= 4.0 * std::sqrt(M * p * (1.0 - p)));
    }
}

TEST_CASE("Metropolis start-up bias: a single seed follows 004 eq. 51, seeds by importance remove it",
          "[sampling][metropolis]") {
    const double delta = 0.1;
    const int N = 20000, K = 12;
    for (const int n : {4, 16, 64}) {
        const auto single = chains_after(n, false, N, K, delta);
        const auto seeded = chains_after(n, true, N, K, delta);
        // Eq. 51: ||p_n - p_inf||^2 = (1 / 2 pi) sum_{k != 0} |P*(k)|^(2n) on [-pi, pi];
        // measured from the coefficients, |c_k|^2 less its noise (1 - |c_k|^2) / N.
        double predicted = 0.0, measured = 0.0, measured_seeded = 0.0, noise = 0.0;
        for (int k = 1; k <= K; ++k) {
            const double pk = std::pow(characteristic(k, delta), 2 * n);
            predicted += 2.0 * pk / (2.0 * M_PI);
            auto unbiased = [&](std::complex<double> ck) { return (N * std::norm(ck) - 1.0) / (N - 1.0); };
            measured += 2.0 * unbiased(single[static_cast<std::size_t>(k)]) / (2.0 * M_PI);
            measured_seeded += 2.0 * unbiased(seeded[static_cast<std::size_t>(k)]) / (2.0 * M_PI);
            // The spread of |c_k|^2's estimate, near |c_k| ~ 0 (generous above it).
            noise += 2.0 * (2.0 * std::sqrt(pk) / std::sqrt(N) + 1.0 / N) / (2.0 * M_PI);
        }
        INFO("n = " << n << ": predicted " << predicted << ", single seed " << measured << ", seeded "
                    << measured_seeded << ", noise " << noise);
        CHECK(std::abs(measured - predicted) < 4.0 * noise);
        CHECK(std::abs(measured_seeded) < 4.0 * noise);
        // The bias itself: E[cos x_n] = P*(1)^n for one seed, 0 once seeded.
        const double sigma = 1.0 / std::sqrt(N);
        CHECK(std::abs(single[1].real() - std::pow(characteristic(1, delta), n)) < 4.0 * sigma);
        CHECK(std::abs(seeded[1].real()) < 4.0 * sigma);
        if (n <= 16) CHECK(measured > 10.0 * noise);  // a bias the test can see
    }
}

TEST_CASE("VEGAS: unbiased on a peaked integrand, and its variance far below uniform sampling",
          "[sampling][vegas]") {
    const double exact = test::peak_integral();
    sampling::VegasTables tables(2, 16);
    sampling::Rng rng(3, 11);
    double z[4];
    // Learning phases of 2,000 samples.
    for (int phase = 0; phase < 10; ++phase) {
        for (int m = 0; m < 2000; ++m) {
            const double p = tables.sample(rng, z);
            tables.accumulate(z, test::peak(z) / p);
        }
        tables.refine();
    }
    CHECK(tables.refinements() == 10);
    // Then estimates with the tables fixed, against uniform sampling.
    const int M = 100000;
    double sum = 0.0, sum2 = 0.0, usum = 0.0, usum2 = 0.0;
    for (int m = 0; m < M; ++m) {
        const double p = tables.sample(rng, z);
        CHECK(p == Approx(tables.density(z)).epsilon(1e-12));
        const double v = test::peak(z) / p;
        sum += v;
        sum2 += v * v;
        for (double& u : z) u = rng.uniform();
        const double w = test::peak(z);
        usum += w;
        usum2 += w * w;
    }
    const double mean = sum / M, var = sum2 / M - mean * mean;
    const double umean = usum / M, uvar = usum2 / M - umean * umean;
    INFO("exact " << exact << ", VEGAS " << mean << " (variance " << var << "), uniform " << umean << " (variance "
                  << uvar << ")");
    CHECK(std::abs(mean - exact) < 4.0 * std::sqrt(var / M));
    CHECK(std::abs(umean - exact) < 4.0 * std::sqrt(uvar / M));
    CHECK(var * 5.0 < uvar);
}

TEST_CASE("VEGAS tables: any tables give an unbiased estimate (a density that integrates to 1)", "[sampling][vegas]") {
    sampling::VegasTables tables(1, 8);
    sampling::Rng rng(9, 1);
    double z[2];
    // Skewed tables: refined on an importance that is all in one corner.
    for (int m = 0; m < 4000; ++m) {
        const double p = tables.sample(rng, z);
        tables.accumulate(z, (z[0] < 0.2 && z[1] < 0.2 ? 1.0 : 0.0) / p);
    }
    tables.refine();
    tables.refine();
    // E[1 / p] = the domain's volume, 1, for the uniform integrand 1.
    const int M = 200000;
    double sum = 0.0, sum2 = 0.0;
    for (int m = 0; m < M; ++m) {
        const double v = 1.0 / tables.sample(rng, z);
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / M, se = std::sqrt((sum2 / M - mean * mean) / M);
    INFO("E[1/p] = " << mean << " +- " << se);
    CHECK(std::abs(mean - 1.0) < 4.0 * se);
    CHECK(se > 0.0);  // the tables did move away from uniform
}

namespace {

double walks_mean(const scenes::Scene& scene, sampling::SamplerKind sampler, long walks, std::uint64_t seed,
                  solver::SolverReport* report = nullptr, long seed_walks = 0) {
    auto backend = visibility::make_backend("painter", scene, {});
    const solver::Transport transport(scene);
    solver::SolverOptions opt;
    opt.depth = 3;
    opt.steps = walks;
    opt.sampler = sampler;
    opt.seed_walks = seed_walks;
    sampling::RunOptions run;
    run.seed = seed;
    solver::GlobalWalks w(transport, *backend, solver::WalkMethod::walk, opt, run);
    w.run();
    if (report) *report = w.report();
    return w.field().mean_radiance(scene);
}

}  // namespace

TEST_CASE("VEGAS and Metropolis walks reach what random walks reach on the homogeneous box", "[solver][walks][vegas]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    const double exact = 1.0 - std::ldexp(1.0, -4);  // D = 3
    const int K = 12;
    auto over_seeds = [&](sampling::SamplerKind sampler) {
        double sum = 0.0, sum2 = 0.0;
        for (int k = 0; k < K; ++k) {
            const double m = walks_mean(scene, sampler, 1200, 100 + static_cast<std::uint64_t>(k));
            sum += m;
            sum2 += m * m;
        }
        const double mean = sum / K;
        return std::pair{mean, std::sqrt(std::max(0.0, sum2 / K - mean * mean) / (K - 1))};
    };
    const auto [random, random_se] = over_seeds(sampling::SamplerKind::random);
    for (const auto sampler : {sampling::SamplerKind::vegas, sampling::SamplerKind::metropolis}) {
        const auto [mean, se] = over_seeds(sampler);
        INFO(sampling::sampler_name(sampler) << ": " << mean << " +- " << se << ", random " << random << " +- "
                                             << random_se << ", exact " << exact);
        CHECK(std::abs(mean - random) < 4.0 * std::hypot(se, random_se) + 1e-4);
        CHECK(std::abs(mean - exact) < 4.0 * se + 0.005);  // the painter's bias, about 0.2 %
        CHECK(se < 0.012);
    }
    solver::SolverReport report;
    walks_mean(scene, sampling::SamplerKind::metropolis, 100, 1, &report);
    const auto& m = report.details.at("metropolis");
    CHECK(m.at("seed_walks").get<long>() == 30);  // 30 % of the walks
    CHECK(m.at("proposed").get<long>() == 70);
    CHECK(m.at("learning_steps").get<long>() == 14);  // 20 % of the steps
    CHECK(m.at("image_steps").get<long>() == 56);
    CHECK(m.at("density_refreshes").get<long>() == 1);  // at the end of the learning (before 16 steps)
    CHECK_FALSE(m.at("seeding").get<bool>());
    CHECK(m.at("acceptance_rate").get<double>() > 0.5);  // a homogeneous scene: nearly constant importance
    CHECK(m.at("exposure").get<double>() > 0.0);
    // A run that is all seeds is a run of uniform walks: its field is their mean.
    const double seeds_only = walks_mean(scene, sampling::SamplerKind::metropolis, 300, 2, &report, 300);
    CHECK(report.details.at("metropolis").at("proposed").get<long>() == 0);
    // 4 sigma of one run of 300 random walks (0.009: the 1,200-walk runs above spread
    // 0.0047), and the painter's 0.5 %.
    CHECK(std::abs(seeds_only - exact) < 0.04);
    walks_mean(scene, sampling::SamplerKind::vegas, 200, 1, &report);
    CHECK(report.details.at("vegas").at("refinements").get<long>() == 3);
}
