// Stochastic iteration on the homogeneous box, whose exact radiance is 1 everywhere:
// error level, M^(-1/2) convergence, bias, determinism. These study the estimator of
// 004 section 4.4.1 as it is (SolverOptions::ambient off, as by default): the ambient
// control variate makes this box nearly exact (tests/solver/test_stress.cpp).
#include "reference.h"
#include "scenes/builtin.h"
#include "solver/global_walks.h"
#include "solver/stochastic_iteration.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <vector>

using namespace raybundle;

namespace {

struct Run {
    std::map<long, double> error;  // iteration -> relative L1 error
    solver::RadianceField field;
};

Run solve(const scenes::Scene& scene, long iterations, std::uint64_t seed, long every, bool both = false) {
    auto backend = visibility::make_backend("painter", scene, {});
    solver::SolverOptions opt;
    sampling::RunOptions opt_run;
    opt.both_ways = both;
    opt.ambient = false;
    opt.steps = iterations;
    opt_run.seed = seed;
    opt_run.progress_every = every;
    Run run;
    const solver::StochasticIteration* solver = nullptr;
    opt_run.progress = [&](const sampling::Progress& p) {
        run.error[p.done] = solver->field().relative_l1_error(scene, 1.0);
    };
    solver::StochasticIteration it(scene, *backend, opt, opt_run);
    solver = &it;
    it.run();
    run.field = it.field();
    return run;
}

// Least-squares slope of log(error) (the values) against log(M) (the keys).
double log_log_slope(const std::map<long, double>& log_error) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (const auto& [m, y] : log_error) {
        const double x = std::log(static_cast<double>(m));
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
        ++n;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

TEST_CASE("homogeneous box: error, M^-1/2 convergence and bias", "[solver][convergence]") {
    const auto scene = scenes::make_builtin("homogeneous-box");
    const Run run = solve(scene, 10000, 1, 100);

    // Error level at 1,000 iterations.
    const double e1000 = run.error.at(1000);
    INFO("relative L1 error at 1000 iterations: " << e1000);
    CHECK(e1000 < 0.05);

    // Least-squares slope of log(error) against log(M) over 100..10,000.
    std::map<long, double> log_error;
    for (const auto& [m, e] : run.error) log_error[m] = std::log(e);
    const double slope = log_log_slope(log_error);
    INFO("fitted slope (w alone): " << slope);
    CHECK(slope > -0.65);
    CHECK(slope < -0.35);

    // Bias: the area-weighted mean radiance after 10,000 iterations.
    const double mean = run.field.mean_radiance(scene);
    INFO("mean radiance: " << mean);
    CHECK(std::abs(mean - 1.0) < 0.003);
    CHECK(run.error.at(10000) < run.error.at(1000) / 2.0);
}

TEST_CASE("iteration with both w and -w converges as M^-1/2", "[solver][convergence]") {
    // The error of one run wanders (consecutive steps share their irradiance), so the
    // slope is fitted to the geometric mean of 4 seeds' errors.
    const auto scene = scenes::make_builtin("homogeneous-box");
    const int K = 4;
    std::map<long, double> log_error;
    for (int k = 0; k < K; ++k)
        for (const auto& [m, e] : solve(scene, 10000, 1 + k, 100, true).error) log_error[m] += std::log(e) / K;
    const double slope = log_log_slope(log_error);
    INFO("fitted slope (w and -w, 4 seeds): " << slope << ", error at 1000: " << std::exp(log_error.at(1000)));
    CHECK(slope > -0.65);
    CHECK(slope < -0.35);
    CHECK(std::exp(log_error.at(1000)) < 0.015);
}

TEST_CASE("iteration with both w and -w: unbiased, and a smaller error", "[solver][convergence]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    auto run = [&](bool both, std::uint64_t seed, long iterations) {
        auto backend = visibility::make_backend("painter", scene, {});
        solver::SolverOptions opt;
        sampling::RunOptions opt_run;
        opt.steps = iterations;
        opt_run.seed = seed;
        opt.both_ways = both;
        opt.ambient = false;
        solver::StochasticIteration it(scene, *backend, opt, opt_run);
        it.run();
        return it.field();
    };
    // Unbiased: the mean radiance over 8 seeds within 3 standard errors of 1.
    const int K = 8;
    double sum = 0.0, sum2 = 0.0;
    for (int k = 0; k < K; ++k) {
        const double m = run(true, 100 + k, 2000).mean_radiance(scene);
        sum += m;
        sum2 += m * m;
    }
    const double mean = sum / K, se = std::sqrt((sum2 / K - mean * mean) / (K - 1));
    INFO("mean " << mean << ", standard error " << se);
    CHECK(std::abs(mean - 1.0) < 3.0 * se + 1e-4);
    CHECK(se < 0.002);
    // At 1,000 steps (measured: 4.3 % for w alone, 1.0 % for both on the default box).
    const double one = run(false, 1, 1000).relative_l1_error(scene, 1.0);
    const double both = run(true, 1, 1000).relative_l1_error(scene, 1.0);
    INFO("w alone " << one << ", both " << both);
    CHECK(both < 0.5 * one);
    CHECK(both < 0.02);
}

TEST_CASE("the same seed gives bit-identical results, another seed does not", "[solver][determinism]") {
    const auto scene = scenes::make_builtin("homogeneous-box", 0.34);
    const Run a = solve(scene, 300, 77, 0), b = solve(scene, 300, 77, 0), c = solve(scene, 300, 78, 0);
    REQUIRE(a.field.radiance.size() == b.field.radiance.size());
    bool all_equal = true, any_differs = false;
    for (std::size_t i = 0; i < a.field.radiance.size(); ++i) {
        all_equal = all_equal && (a.field.radiance[i] == b.field.radiance[i]).all();
        any_differs = any_differs || !(a.field.radiance[i] == c.field.radiance[i]).all();
    }
    CHECK(all_equal);
    CHECK(any_differs);
}

TEST_CASE("a glossy scene takes the view-dependent path and agrees with unbiased random walks", "[solver][glossy]") {
    // The homogeneous box with half the albedo made glossy: no closed form, so two
    // independent unbiased estimators of the full solution must agree: stochastic
    // iteration and unbiased random walks, 4 seeds each, within 4 standard errors.
    auto scene = testing::glossy_box(0.34);
    auto backend = visibility::make_backend("painter", scene, {});
    const solver::Transport transport(scene);
    std::vector<double> iteration, walks;
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    sampling::RunOptions run;
        run.seed = seed;
        solver::SolverOptions it_opt;
        it_opt.steps = 2000;
        solver::StochasticIteration it(transport, *backend, it_opt, run);
        CHECK(it.report().decisions["shading"].get<std::string>().find("glossy") != std::string::npos);
        it.run();
        iteration.push_back(it.field().mean_radiance(scene));
        solver::SolverOptions walk_opt;
        walk_opt.steps = 600;
        walk_opt.depth = 4;
        walk_opt.unbiased = true;
        solver::GlobalWalks w(transport, *backend, solver::WalkMethod::bidirectional, walk_opt, run);
        w.run();
        walks.push_back(w.field().mean_radiance(scene));
    }
    auto mean_se = [](const std::vector<double>& v) {
        double m = 0.0, q = 0.0;
        for (double x : v) m += x / v.size();
        for (double x : v) q += (x - m) * (x - m);
        return std::make_pair(m, std::sqrt(q / (v.size() - 1) / v.size()));
    };
    const auto [mi, si] = mean_se(iteration);
    const auto [mw, sw] = mean_se(walks);
    INFO("iteration " << mi << " +- " << si << ", unbiased walks " << mw << " +- " << sw);
    CHECK(std::abs(mi - mw) < 4.0 * std::hypot(si, sw));
    // Below the diffuse box's 1 (the lobe loses energy at grazing angles), above one bounce.
    CHECK(mi < 0.99);
    CHECK(mi > 0.75);
}
