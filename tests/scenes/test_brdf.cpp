// BRDFs: energy conservation and reciprocity, integrated numerically.
#include "sampling/directions.h"
#include "sampling/rng.h"
#include "scenes/brdf.h"
#include "scenes/frame.h"

#include <catch2/catch.hpp>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;

TEST_CASE("diffuse and modified Phong BRDFs conserve energy", "[solver][brdf]") {
    scenes::Material m;
    m.albedo = Rgb(0.5, 0.2, 0.0);
    m.specular = Rgb(0.45, 0.7, 0.95);
    m.exponent = GENERATE(1.0, 10.0, 100.0);
    const Vec3 n(0, 0, 1);
    for (double theta_deg : {0.0, 30.0, 60.0, 85.0}) {
        const double t = theta_deg * M_PI / 180.0;
        const Vec3 w_in(std::sin(t), 0.0, -std::cos(t));  // arriving from above
        const Rgb a = scenes::directional_albedo(m, n, w_in, 400);
        INFO("exponent " << m.exponent << ", incidence " << theta_deg);
        CHECK((a <= 1.0 + 1e-3).all());
        CHECK((a <= m.albedo + m.specular + 1e-3).all());
        if (theta_deg == 0.0 && m.exponent <= 10.0)  // at normal incidence the lobe is (nearly) all inside
            CHECK(a[2] == Approx(m.albedo[2] + m.specular[2]).epsilon(0.01));
    }
    scenes::Material lambert;
    lambert.albedo = Rgb(0.3, 0.6, 0.9);
    const Rgb a = scenes::directional_albedo(lambert, n, Vec3(0.3, 0.0, -1.0).normalized(), 400);
    CHECK(a[0] == Approx(0.3).epsilon(1e-4));
    CHECK(a[2] == Approx(0.9).epsilon(1e-4));
}

TEST_CASE("the BRDFs are reciprocal and one-sided", "[solver][brdf]") {
    scenes::Material m;
    m.albedo = Rgb::Constant(0.3);
    m.specular = Rgb::Constant(0.5);
    m.exponent = 25.0;
    const Vec3 n = Vec3(0.2, -0.4, 0.9).normalized();
    sampling::RandomDirections dirs(5);
    int checked = 0;
    while (checked < 200) {
        const Vec3 a = dirs.next(), b = dirs.next();
        if (a.dot(n) >= 0.0 || b.dot(n) <= 0.0) continue;  // a arrives, b leaves
        // Reversing the path: arrive along -b, leave along -a.
        const Rgb f1 = scenes::brdf(m, n, a, b), f2 = scenes::brdf(m, n, -b, -a);
        CHECK((f1 - f2).abs().maxCoeff() <= 1e-12 * (1.0 + f1.maxCoeff()));
        CHECK((scenes::brdf(m, n, -a, b) == 0.0).all());  // arriving from behind
        ++checked;
    }
}

TEST_CASE("BRDF sampling: the density integrates to 1 and the estimator gives the albedo", "[solver][brdf]") {
    scenes::Material m;
    m.albedo = scenes::Rgb(0.3, 0.2, 0.1);
    m.specular = scenes::Rgb(0.5, 0.6, 0.7);
    m.exponent = 40.0;
    const Vec3 n = Vec3(0.2, 0.3, 1.0).normalized();
    for (const double tilt : {0.1, 0.8, 1.4}) {
        // w_out tilted from the normal by `tilt` radians.
        Vec3 u, v;
        scenes::orthonormal_basis(n, u, v);
        const Vec3 w_out = std::cos(tilt) * n + std::sin(tilt) * u;
        // The density over the whole sphere (the lobe may reach below the horizon).
        const int N = 2000;
        double total = 0.0;
        for (int a = 0; a < N; ++a)
            for (int b = 0; b < N; ++b) {
                const Vec3 w = sampling::uniform_sphere((a + 0.5) / N, (b + 0.5) / N);
                total += scenes::brdf_pdf(m, n, w_out, w);
            }
        CHECK(total * 4.0 * M_PI / (double(N) * N) == Approx(1.0).epsilon(2e-3));
        // E[f cos / pdf] over sampled directions is the directional albedo (reciprocity).
        sampling::Rng rng(11, 0);
        scenes::Rgb sum = scenes::Rgb::Zero();
        const int samples = 400000;
        for (int i = 0; i < samples; ++i) {
            const auto s = scenes::sample_brdf(m, n, w_out, rng.uniform(), rng.uniform(), rng.uniform());
            REQUIRE(s.pdf == Approx(scenes::brdf_pdf(m, n, w_out, s.direction)));
            const double c = n.dot(s.direction);
            if (c > 0.0 && s.pdf > 0.0) sum += scenes::brdf(m, n, -s.direction, w_out) * (c / s.pdf);
        }
        const scenes::Rgb expected = scenes::directional_albedo(m, n, -w_out, 800);
        for (int k = 0; k < 3; ++k) CHECK(sum[k] / samples == Approx(expected[k]).epsilon(0.01));
    }
}
