// Refinement driven by the solution (render/adaptive.h): the variation it measures,
// the cuts it plans, and what they are worth against an exact answer.
#include "render/adaptive.h"
#include "render/run.h"
#include "scenes/builtin.h"
#include "scenes/subdivide.h"
#include "solver/form_factor.h"
#include "visibility/backend.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <set>

using namespace raybundle;
using scenes::Rgb;
using scenes::Vec3;

namespace {

// A field on the box's patches: 1 everywhere, `low` on the floor (y = 0) where x > 0.5,
// each chain with its own noise of standard deviation `sigma` per patch.
std::pair<solver::RadianceField, solver::RadianceField> step_fields(const scenes::Scene& s, double low, double sigma) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, sigma);
    solver::RadianceField a, b;
    for (const auto& p : s.patch_list()) {
        const double truth = p.centroid.y() < 1e-9 && p.centroid.x() > 0.5 ? low : 1.0;
        a.radiance.push_back(Rgb::Constant(truth + noise(rng)));
        b.radiance.push_back(Rgb::Constant(truth + noise(rng)));
    }
    return {a, b};
}

// Has patch p of the floor an edge on the line x = 0.5, where the step is?
bool on_step(const scenes::Scene& s, const scenes::Patch& p) {
    if (p.centroid.y() > 1e-9) return false;
    int on = 0;
    for (int v : p.v) on += std::abs(s.vertex_positions()[v].x() - 0.5) < 1e-9;
    return on == 2;
}

}  // namespace

TEST_CASE("variation: a step of the radiance is seen beyond the noise, noise alone is not a step",
          "[render][adaptive]") {
    const scenes::Scene s = scenes::make_builtin("homogeneous-box", 0.125);
    SECTION("a constant field varies nowhere") {
        const auto [a, b] = step_fields(s, 1.0, 0.0);
        for (double v : render::variation(s, a, b)) REQUIRE(v == 0.0);
    }
    SECTION("the step's patches, and only theirs, vary; noise is subtracted, not added") {
        const auto [a, b] = step_fields(s, 0.2, 0.02);
        const auto v = render::variation(s, a, b);
        double step_min = 1.0, other_max = 0.0, other_mean = 0.0;
        std::size_t others = 0;
        for (std::size_t i = 0; i < s.patch_count(); ++i) {
            const auto& p = s.patch_list()[i];
            // Patches with an edge on the step line see a neighbour 0.8 away; the
            // crease between the floor and the walls is not crossed.
            if (on_step(s, p)) {
                step_min = std::min(step_min, v[i]);
            } else {
                other_max = std::max(other_max, v[i]);
                other_mean += v[i];
                ++others;
            }
        }
        other_mean /= static_cast<double>(others);
        INFO("step patches at least " << step_min << ", others at most " << other_max << ", mean " << other_mean);
        // A patch with one neighbour of three across the step: 0.8 / sqrt(3) = 0.46 (one
        // with two of three: 0.65); pure noise of 0.02 per chain: its mean's deviation
        // is 0.014, and what is left after the subtraction is of that order.
        CHECK(step_min > 0.4);
        CHECK(other_max < 0.1);
        CHECK(other_mean < 0.014);
    }
}

TEST_CASE("plan_refinement: the growth goes where area x variation is, deepest where it is largest",
          "[render][adaptive]") {
    const scenes::Scene s = scenes::make_builtin("homogeneous-box", 0.125);
    const auto [a, b] = step_fields(s, 0.2, 0.02);
    const auto v = render::variation(s, a, b);
    // 1,536 patches, 16 of them with an edge on the step: one level for each of those adds
    // 48 patches, two levels 240 (a third would add 768, and gain per patch what cutting
    // the noise's leftovers gains).
    const double growth = GENERATE(0.25, 1.0);
    const render::RefinePlan plan = render::plan_refinement(s, v, growth);
    INFO("growth " << growth << ": " << plan.marked << " marked, " << plan.planned << " planned, deepest "
                   << plan.deepest << ", covered " << plan.covered);
    CHECK(plan.planned <= growth * static_cast<double>(s.patch_count()));
    CHECK(plan.planned >= 0.9 * growth * static_cast<double>(s.patch_count()));
    // Every step patch is cut, and at least as deep as any other (the step's variation
    // is tens of times what the noise leaves): the levels read back from the sizes.
    auto level = [&](std::size_t i) {
        if (!std::isfinite(plan.max_edge[i])) return 0;
        const auto& p = s.patch_list()[i];
        double longest = 0.0;
        for (int k = 0; k < 3; ++k)
            longest = std::max(longest, (s.vertex_positions()[p.v[k]] - s.vertex_positions()[p.v[(k + 1) % 3]]).norm());
        return static_cast<int>(std::lround(std::log2(longest / plan.max_edge[i])));
    };
    int least_on_step = 99, most_elsewhere = 0;
    std::size_t step_patches = 0;
    for (std::size_t i = 0; i < s.patch_count(); ++i) {
        if (std::isfinite(plan.max_edge[i])) CHECK(v[i] > 0.0);
        if (on_step(s, s.patch_list()[i]))
            ++step_patches, least_on_step = std::min(least_on_step, level(i));
        else
            most_elsewhere = std::max(most_elsewhere, level(i));
    }
    CHECK(step_patches == 16);
    CHECK(least_on_step == 2);
    CHECK(least_on_step >= most_elsewhere);
    CHECK(render::plan_refinement(s, std::vector<double>(s.patch_count(), 0.0), growth).marked == 0);
}

namespace {

// A 4 x 4 floor of albedo 0.5 under a 0.4 x 0.4 light of radiance 10 (albedo 0) at height
// 0.3, nothing else: the floor's radiance at x is exactly 0.5 x 10 x F(x -> light).
constexpr double kLight = 10.0, kAlbedo = 0.5, kHeight = 0.3;

scenes::Scene floor_under_a_lamp(double patch_size) {
    scenes::Scene s;
    s.name = "floor under a lamp";
    scenes::Material floor, lamp;
    floor.name = "floor";
    floor.albedo = Rgb::Constant(kAlbedo);
    lamp.name = "lamp";
    lamp.emission = Rgb::Constant(kLight);
    const int f = s.add_material(floor), l = s.add_material(lamp);
    s.add_object({{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}}, {{{0, 1, 2}}, {{0, 2, 3}}}, f, "floor");
    s.add_object({{-0.2, kHeight, -0.2}, {0.2, kHeight, -0.2}, {0.2, kHeight, 0.2}, {-0.2, kHeight, 0.2}},
                 {{{0, 1, 2}}, {{0, 2, 3}}}, l, "lamp");
    s.camera.eye = {0, 3, 0.01};
    s.camera.target = {0, 0, 0};
    s.camera.width = s.camera.height = 16;
    s.finalize();
    scenes::subdivide(s, patch_size);
    return s;
}

double exact_floor_radiance(const Vec3& x) {
    const Vec3 n(0, 1, 0);
    const Vec3 c[4] = {{-0.2, kHeight, -0.2}, {0.2, kHeight, -0.2}, {0.2, kHeight, 0.2}, {-0.2, kHeight, 0.2}};
    const double form = solver::point_to_triangle(x, n, {c[0], c[1], c[2]}) + solver::point_to_triangle(x, n, {c[0], c[2], c[3]});
    return kAlbedo * kLight * form;
}

// The field's L1 error on the floor against the exact radiance, relative to the exact
// radiance's integral: each patch's constant against the exact value at 36 points of it.
double floor_error(const scenes::Scene& s, const solver::RadianceField& field) {
    double error = 0.0, total = 0.0;
    const auto& pos = s.vertex_positions();
    constexpr int kN = 8;
    for (std::size_t i = 0; i < s.patch_count(); ++i) {
        const auto& p = s.patch_list()[i];
        if (p.normal.y() < 0.5) continue;
        double e = 0.0, t = 0.0;
        int count = 0;
        for (int u = 0; u < kN; ++u)
            for (int w = 0; u + w < kN; ++w) {
                const double b1 = (u + 1.0 / 3.0) / kN, b2 = (w + 1.0 / 3.0) / kN;
                const Vec3 x = (1.0 - b1 - b2) * pos[p.v[0]] + b1 * pos[p.v[1]] + b2 * pos[p.v[2]];
                const double exact = exact_floor_radiance(x);
                e += std::abs(field.radiance[i].mean() - exact);
                t += exact;
                ++count;
            }
        error += p.area * e / count;
        total += p.area * t / count;
    }
    return error / total;
}

render::RunConfig field_only() {
    render::RunConfig c;
    c.solver.steps = 16;  // the floor's light is the diffuse shot's; the steps only move it on
    c.gather.gather_rays = 0;
    c.run.threads = 2;
    return c;
}

}  // namespace

TEST_CASE("refinement by the solution: cuts where the light varies beat uniform cuts at the same count",
          "[render][adaptive][run]") {
    // The diffuse shot makes the floor's light exact up to quadrature, so the pilot sees
    // the light's falloff without noise. Uniform refinement to about as many patches
    // (and more) against refinement by the solution from a coarse start: the field's
    // error against the exact radiance.
    const scenes::Scene coarse = floor_under_a_lamp(0.25);
    render::RunConfig refine = field_only();
    refine.refine.on = true;
    refine.refine.growth = 2.0;
    const render::RunResult adaptive = render::run(coarse, refine);
    REQUIRE(adaptive.refined);
    REQUIRE(adaptive.field->radiance.size() == adaptive.refined->patch_count());
    const double adaptive_error = floor_error(*adaptive.refined, *adaptive.field);

    const scenes::Scene uniform_scene = floor_under_a_lamp(0.125);
    const render::RunResult uniform = render::run(uniform_scene, field_only());
    const double uniform_error = floor_error(uniform_scene, *uniform.field);
    const double coarse_error = floor_error(coarse, *render::run(coarse, field_only()).field);
    INFO("coarse " << coarse.patch_count() << " patches: error " << coarse_error << "; refined by the solution "
                   << adaptive.refined->patch_count() << ": " << adaptive_error << "; uniform "
                   << uniform_scene.patch_count() << ": " << uniform_error);
    CHECK(adaptive.refined->patch_count() <= uniform_scene.patch_count());
    CHECK(adaptive_error < 0.6 * uniform_error);
    CHECK(uniform_error < 0.6 * coarse_error);
    // The record says what was done.
    const auto& r = adaptive.record.at("refinement");
    CHECK(r.at("patches_before").get<std::size_t>() == coarse.patch_count());
    CHECK(r.at("patches_after").get<std::size_t>() == adaptive.refined->patch_count());
    CHECK(adaptive.record.at("decisions").at("refinement").get<std::string>().find("by the solution") == 0);
    CHECK(adaptive.record.at("patches").get<std::size_t>() == adaptive.refined->patch_count());
    // The map keeps the resolution of the scene as given.
    CHECK(adaptive.record.at("resolution").get<int>() == visibility::default_resolution(coarse));
    // The same seed gives the same refined scene and field, to the bit, on any number of
    // threads.
    render::RunConfig one_thread = refine;
    one_thread.run.threads = 1;
    const render::RunResult again = render::run(coarse, one_thread);
    REQUIRE(again.refined->patch_count() == adaptive.refined->patch_count());
    bool same = true;
    for (std::size_t i = 0; i < again.field->radiance.size(); ++i)
        same = same && (again.field->radiance[i] == adaptive.field->radiance[i]).all();
    CHECK(same);
    // Off, the scene given is the scene solved.
    CHECK_FALSE(uniform.refined);
}
