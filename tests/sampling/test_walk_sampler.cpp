// The walk samplers: reproducible, uniform, and (QMC) stratified as their
// construction promises.
#include "sampling/walk_sampler.h"

#include <catch2/catch.hpp>

#include <cmath>
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
    // Dimensions 0 and 1 form a (0, m, 2)-net: 16 x 16 cells of 256 points, one each.
    std::vector<int> cells(256, 0);
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        ++cells[static_cast<int>(s.coordinate(0) * 16) * 16 + static_cast<int>(s.coordinate(1) * 16)];
    }
    for (int c : cells) CHECK(c == 1);
}

TEST_CASE("halton: the first b^k points are one per interval of length b^-k", "[sampling]") {
    WalkSampler s(SamplerKind::halton, 2, 9);
    // Dimension 1 has base 3: 3^5 = 243 points.
    const int K = 243;
    std::vector<int> count(K, 0);
    for (int m = 0; m < K; ++m) {
        s.start_walk(static_cast<std::uint64_t>(m));
        ++count[static_cast<int>(s.coordinate(1) * K)];
    }
    for (int c : count) CHECK(c == 1);
}

TEST_CASE("walk samplers: bad arguments are refused with a message", "[sampling]") {
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::sobol, 16, 1), Catch::Contains("up to 15"));
    CHECK_THROWS_WITH(WalkSampler(SamplerKind::random, 0, 1), Catch::Contains(">= 1"));
    CHECK_THROWS_WITH(parse_sampler("owen"), Catch::Contains("known: random, halton, sobol"));
}
