// The walk samplers: reproducible, uniform, and (QMC) stratified as their
// construction promises.
#include "sampling/walk_sampler.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

using namespace raybundle::sampling;

TEST_CASE("walk samplers: the same seed and walk give the same point, in any order", "[sampling]") {
    for (auto kind : {SamplerKind::random, SamplerKind::halton, SamplerKind::sobol}) {
        WalkSampler a(kind, 5, 7), b(kind, 5, 7), c(kind, 5, 8);
        b.start_walk(3);  // visit another walk first
        a.start_walk(11);
        b.start_walk(11);
        c.start_walk(11);
        bool differs = false;
        for (int k = 0; k < 10; ++k) {
            CHECK(a.coordinate(k) == b.coordinate(k));
            differs = differs || a.coordinate(k) != c.coordinate(k);
            CHECK(a.coordinate(k) >= 0.0);
            CHECK(a.coordinate(k) < 1.0);
        }
        CHECK(differs);
        for (int d = 0; d < 5; ++d) CHECK(std::abs(a.direction(d).norm() - 1.0) < 1e-12);
    }
}

TEST_CASE("walk samplers: every coordinate is uniform", "[sampling]") {
    // Mean and second moment of each coordinate over 4096 walks: 1/2 and 1/3.
    for (auto kind : {SamplerKind::random, SamplerKind::halton, SamplerKind::sobol}) {
        WalkSampler s(kind, 6, 3);
        const int N = 4096;
        std::vector<double> m1(12, 0.0), m2(12, 0.0);
        for (int m = 0; m < N; ++m) {
            s.start_walk(static_cast<std::uint64_t>(m));
            for (int k = 0; k < 12; ++k) {
                m1[k] += s.coordinate(k) / N;
                m2[k] += s.coordinate(k) * s.coordinate(k) / N;
            }
        }
        // Random points: 5 standard errors (1/sqrt(12 N) = 0.0045); QMC far closer.
        const double tol = kind == SamplerKind::random ? 0.023 : 0.002;
        for (int k = 0; k < 12; ++k) {
            INFO(sampler_name(kind) << " coordinate " << k);
            CHECK(std::abs(m1[k] - 0.5) < tol);
            CHECK(std::abs(m2[k] - 1.0 / 3.0) < tol);
        }
    }
}

TEST_CASE("sobol: the first 2^k points put one point in each of 2^k intervals, per dimension", "[sampling]") {
    WalkSampler s(SamplerKind::sobol, WalkSampler::kMaxSobolDepth, 5);
    const int K = 1 << 8;
    std::vector<std::vector<int>> count(30, std::vector<int>(K, 0));
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        for (int k = 0; k < 30; ++k) ++count[k][static_cast<int>(s.coordinate(k) * K)];
    }
    for (int k = 0; k < 30; ++k) {
        INFO("dimension " << k);
        for (int c : count[k]) CHECK(c == 1);
    }
    // The last direction's coordinates form a (0, m, 2)-net: 16 x 16 cells of 256
    // points, one each.
    const int last = 2 * (WalkSampler::kMaxSobolDepth - 1);
    std::vector<int> cells(256, 0);
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        ++cells[static_cast<int>(s.coordinate(last) * 16) * 16 + static_cast<int>(s.coordinate(last + 1) * 16)];
    }
    for (int c : cells) CHECK(c == 1);
}

namespace {

// The t-value of the 2-D projection (coordinates a, b) of the first 2^m points: the
// smallest t such that every elementary box of area 2^(t-m) holds 2^t of them.
int t_value(const std::vector<std::vector<double>>& x, int a, int b, int m) {
    const std::size_t n = std::size_t{1} << m;
    for (int t = 0; t <= m; ++t) {
        bool net = true;
        for (int bits_a = 0; bits_a <= m - t && net; ++bits_a) {
            const int bits_b = m - t - bits_a;
            std::vector<std::size_t> count(std::size_t{1} << (m - t), 0);
            for (std::size_t i = 0; i < n; ++i) {
                const auto cell_a = static_cast<std::size_t>(std::ldexp(x[i][a], bits_a));
                const auto cell_b = static_cast<std::size_t>(std::ldexp(x[i][b], bits_b));
                ++count[(cell_a << bits_b) | cell_b];
            }
            for (std::size_t c : count) net = net && c == (std::size_t{1} << t);
        }
        if (net) return t;
    }
    return m;
}

}  // namespace

TEST_CASE("sobol: every direction is a good 2-D net, the last the best, at every power of two", "[sampling]") {
    // A direction is a 2-D point on the sphere: its pair of Sobol dimensions must be a
    // (t, m, 2)-net with small t for every count, not only in 1-D. In the sequence's
    // plain order, direction 5 (dimensions 8 and 9) has t = 3 and filled half of a
    // 16 x 16 grid with 512 points: two chains of 500 plain walks were 2x worse than
    // random ones on the homogeneous box (issue 29). The last direction, along which
    // every bounce arrives, takes the (0, 2)-net.
    const int D = WalkSampler::kMaxSobolDepth, M = 12;
    WalkSampler s(SamplerKind::sobol, D, 3);
    std::vector<std::vector<double>> x(std::size_t{1} << M, std::vector<double>(2 * D));
    for (std::size_t i = 0; i < x.size(); ++i) {
        s.start_walk(i);
        for (int k = 0; k < 2 * D; ++k) x[i][k] = s.coordinate(k);
    }
    for (int d = 0; d < D; ++d) {
        int worst = 0;
        for (int m = 1; m <= M; ++m) worst = std::max(worst, t_value(x, 2 * d, 2 * d + 1, m));
        INFO("direction " << d << " of " << D << ": worst t " << worst);
        if (d == D - 1) CHECK(worst == 0);
        if (d >= D - 9) CHECK(worst <= 2);  // the last nine directions
        CHECK(worst <= 4);
    }
}

TEST_CASE("walk samplers: the two chains of a run are independent randomisations", "[sampling]") {
    // The run's error estimate is the two chains' disagreement: it means something only
    // if their errors are independent. Over 400 seeds, an integral of 64 walks (a
    // product of two directions' coordinates and a discontinuous indicator, exact
    // 1/4 + 0.245) by chain 0 and by chain 1 of the same seed: each unbiased, their
    // errors uncorrelated (|rho| below 0.2, 4 standard errors of a zero correlation),
    // and half the mean squared difference the mean squared error of one chain.
    const int D = 5, seeds = 400, walks = 64;
    const double exact = 0.25 + 0.245;
    for (auto kind : {SamplerKind::random, SamplerKind::halton, SamplerKind::sobol}) {
        std::vector<double> e0, e1;
        for (int seed = 1; seed <= seeds; ++seed) {
            for (std::uint64_t chain : {0, 1}) {
                WalkSampler s(kind, D, static_cast<std::uint64_t>(seed), chain);
                double sum = 0.0;
                for (int m = 0; m < walks; ++m) {
                    s.start_walk(static_cast<std::uint64_t>(m));
                    sum += s.coordinate(0) * s.coordinate(2 * D - 1) + (s.coordinate(1) + s.coordinate(2) < 0.7 ? 1.0 : 0.0);
                }
                (chain == 0 ? e0 : e1).push_back(sum / walks - exact);
            }
        }
        double m0 = 0, m1 = 0, s00 = 0, s11 = 0, s01 = 0, diff2 = 0;
        for (int k = 0; k < seeds; ++k) {
            m0 += e0[k] / seeds;
            m1 += e1[k] / seeds;
            s00 += e0[k] * e0[k] / seeds;
            s11 += e1[k] * e1[k] / seeds;
            s01 += e0[k] * e1[k] / seeds;
            diff2 += (e0[k] - e1[k]) * (e0[k] - e1[k]) / seeds;
        }
        const double rho = (s01 - m0 * m1) / std::sqrt((s00 - m0 * m0) * (s11 - m1 * m1));
        INFO(sampler_name(kind) << ": bias " << m0 << ", " << m1 << "; rms error " << std::sqrt(s00) << ", "
                                << std::sqrt(s11) << "; correlation " << rho << "; half the squared difference "
                                << diff2 / 2);
        CHECK(std::abs(m0) < 4.0 * std::sqrt(s00 / seeds));
        CHECK(std::abs(m1) < 4.0 * std::sqrt(s11 / seeds));
        CHECK(std::abs(rho) < 0.2);
        const double one_chain = 0.5 * (s00 + s11);
        CHECK(diff2 / 2 > 0.7 * one_chain);
        CHECK(diff2 / 2 < 1.4 * one_chain);
    }
}

TEST_CASE("halton: the first b^k points are one per interval of length b^-k", "[sampling]") {
    WalkSampler s(SamplerKind::halton, 2, 9);
    // Coordinate 1 is the first direction's second: of a walk of two directions, the
    // fourth dimension of the sequence (the last direction takes bases 2 and 3), base 7.
    const int K = 7 * 7 * 7;
    std::vector<int> count(K, 0);
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        ++count[static_cast<int>(s.coordinate(1) * K)];
    }
    for (int c : count) CHECK(c == 1);
}

TEST_CASE("halton: the last direction takes bases 2 and 3", "[sampling]") {
    WalkSampler s(SamplerKind::halton, 2, 9);
    // Coordinate 3 (the last direction's second) has base 3: 3^5 = 243 points.
    const int K = 243;
    std::vector<int> count(K, 0);
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        ++count[static_cast<int>(s.coordinate(3) * K)];
    }
    for (int c : count) CHECK(c == 1);
}

TEST_CASE("walk samplers: bad arguments are refused with a message", "[sampling]") {
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::sobol, 16, 1), Catch::Contains("up to 15"));
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::random, 0, 1), Catch::Contains(">= 1"));
    CHECK_THROWS_WITH(parse_sampler("owen"), Catch::Contains("known: random, halton, sobol"));
    // The adaptive samplers draw their points themselves (solver/walk_source.h).
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::vegas, 5, 1), Catch::Contains("adapts to the image"));
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::metropolis, 5, 1), Catch::Contains("adapts to the image"));
}
