// The learnt density of the Metropolis large steps and its exposure estimate
// (sampling/mixture.h): draws that follow the density they report, a learner that gives
// each point to the direction that explains it, and an estimate that stays unbiased while
// its densities learn, with far less variance than uniform draws where the integrand
// hangs on one direction of the walk.
#include "sampling/mixture.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace raybundle::sampling;

namespace {

// One of the walk's three directions inside a small square of its coordinates (the
// cone of a hole, as the light behind a partition): the integral is 3 * 0.05^2.
double one_direction_box(const double* z) {
    double f = 0.0;
    for (int t = 0; t < 3; ++t)
        if (z[2 * t] >= 0.40 && z[2 * t] < 0.45 && z[2 * t + 1] >= 0.70 && z[2 * t + 1] < 0.75) f += 1.0;
    return f;
}
constexpr double kBoxIntegral = 3 * 0.05 * 0.05;

}  // namespace

TEST_CASE("DirectionMixture: its draws follow the density it reports", "[sampling][metropolis]") {
    MixtureLearner learner(3);
    Rng rng(3, 4);
    double z[6];
    for (int i = 0; i < 2000; ++i) {  // points whose third direction sits in one corner
        for (double& u : z) u = rng.uniform();
        z[4] = 0.3 + 0.05 * rng.uniform();
        z[5] = 0.6 + 0.05 * rng.uniform();
        learner.learn(z, 1.0);
    }
    const DirectionMixture p = learner.mixture();
    const int M = 400000, cells = DirectionMixture::cells_per_component();
    double inv = 0.0, inv2 = 0.0;
    std::vector<double> hits(static_cast<std::size_t>(cells), 0.0);
    for (int m = 0; m < M; ++m) {
        const double d = p.sample(rng, z);
        inv += 1.0 / d;
        inv2 += 1.0 / (d * d);
        hits[static_cast<std::size_t>(DirectionMixture::cell_of(z + 4))] += 1.0;
    }
    // E[1/p] = the cube's volume.
    const double mean = inv / M, se = std::sqrt((inv2 / M - mean * mean) / M);
    // The third direction's cells against the density's marginal: the other
    // components leave it uniform, so a cell's share is (u + (1 - u)(c_0 + c_1 + c_2 h_2)) / cells.
    double chi2 = 0.0;
    for (int c = 0; c < cells; ++c) {
        const double share = (p.uniform + (1.0 - p.uniform) * (p.weights[0] + p.weights[1] +
                                                               p.weights[2] * p.cells[2 * static_cast<std::size_t>(cells) + c])) /
                             cells;
        const double expected = share * M;
        chi2 += (hits[c] - expected) * (hits[c] - expected) / expected;
    }
    const double dof = cells - 1;
    INFO("E[1/p] " << mean << " +- " << se << ", chi^2 " << chi2 << " for " << dof << " degrees of freedom");
    CHECK(std::abs(mean - 1.0) < 4.0 * se);
    CHECK(chi2 < dof + 4.0 * std::sqrt(2.0 * dof));
    CHECK(p.weights[2] > 0.9);  // the points' own direction
}

TEST_CASE("MixtureLearner: the marginals give the points to the direction that explains them", "[sampling][metropolis]") {
    MixtureLearner learner(3);
    Rng rng(5, 6);
    double z[6];
    for (int i = 0; i < 3000; ++i) {
        for (double& u : z) u = rng.uniform();
        // Half the points have direction 2 in the corner, a quarter direction 0, the
        // rest nothing in particular.
        const double r = rng.uniform();
        const int t = r < 0.5 ? 2 : r < 0.75 ? 0 : -1;
        if (t >= 0) {
            z[2 * t] = 0.3 + 0.03 * rng.uniform();
            z[2 * t + 1] = 0.6 + 0.03 * rng.uniform();
        }
        learner.learn(z, 1.0);
    }
    const DirectionMixture p = learner.mixture();
    INFO("weights " << p.weights[0] << " " << p.weights[1] << " " << p.weights[2]);
    CHECK(p.weights[2] > p.weights[0]);
    CHECK(p.weights[0] > p.weights[1]);
    const double corner[6] = {0.5, 0.5, 0.5, 0.5, 0.31, 0.61};
    const double elsewhere[6] = {0.5, 0.5, 0.5, 0.5, 0.9, 0.1};
    CHECK(p.density(corner) > 20.0 * p.density(elsewhere));
}

TEST_CASE("MixtureEstimate: unbiased while its densities learn, and far below uniform draws on a one-direction peak",
          "[sampling][metropolis]") {
    // R runs of N samples: the first 200 uniform, then from a density learnt from the
    // hits so far (each weighed by f / p) and refreshed every 200, trusted more as it
    // learns. The first hits of each direction come from uniform draws, so the gain
    // grows with N (measured: 1.5x at 2,000, 3.6x at 4,000, 9x at 8,000).
    const int R = 300, N = 8000;
    double sum = 0.0, sum2 = 0.0;
    Rng rng(8, 9);
    double z[6];
    for (int r = 0; r < R; ++r) {
        MixtureLearner learner(3);
        MixtureEstimate estimate(3);
        for (int i = 0; i < N; ++i) {
            if (i > 0 && i % 200 == 0) estimate.draw_from(learner.mixture(), std::sqrt(1.0 + i));
            const double p = estimate.current().sample(rng, z);
            const double f = one_direction_box(z);
            estimate.add(z, f);
            if (f > 0.0) learner.learn(z, f / p / kBoxIntegral);
        }
        CHECK(estimate.samples() == N);
        const double e = estimate.mean();
        sum += e;
        sum2 += e * e;
    }
    const double mean = sum / R, var = sum2 / R - mean * mean;
    // Uniform draws: f is binomial(3, 0.05^2).
    const double uniform_var = 3.0 * 0.0025 * (1.0 - 0.0025) / N;
    INFO("exact " << kBoxIntegral << ", learnt " << mean << " (variance " << var << "), uniform variance "
                  << uniform_var);
    CHECK(std::abs(mean - kBoxIntegral) < 4.0 * std::sqrt(var / R));
    CHECK(var * 5.0 < uniform_var);
}
