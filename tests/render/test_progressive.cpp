// The image in rounds (render/progressive.h): the error estimate against the true
// error where the answer is exact, a target error reached, and runs that depend on the
// seed alone.
#include "gather_options.h"
#include "render/metrics.h"
#include "render/progressive.h"
#include "render/run.h"
#include "sampling/rng.h"
#include "scenes/builtin.h"
#include "solver/solver.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

using namespace raybundle;

namespace {

struct Made {
    render::RunResult image;
    double true_image_error, true_field_error;
};

// The homogeneous box (radiance 1 everywhere, so every pixel is 1) made in rounds by
// the library's run, as the command line makes it (render/run.h).
Made homogeneous(const solver::SolverOptions& so, const render::FieldImageOptions& io, const render::RoundOptions& ro,
                 std::uint64_t seed, bool diffuse_shot = false, int threads = 2) {
    auto scene = scenes::make_builtin("homogeneous-box", 0.25);
    scene.camera.width = scene.camera.height = 32;
    render::RunConfig config;
    config.solver = so;
    config.solver.steps = io.steps;
    config.gather = io.gather_options;
    config.auto_correction = io.auto_correction;  // off unless a test asks for it
    if (!io.gather) config.gather.gather_rays = 0;
    config.shading = io.shading;
    config.rounds = ro;
    config.diffuse_shot = diffuse_shot;
    config.run.seed = seed;
    config.run.threads = threads;
    Made m{render::run(scene, config), 0.0, 0.0};
    const double exact = m.image.record.at("exact_radiance").get<double>();
    render::Image expected(scene.camera.width, scene.camera.height);
    expected.rgb.assign(expected.rgb.size(), static_cast<float>(exact));
    m.true_image_error = render::relative_l1(m.image.image, expected);
    m.true_field_error = m.image.field->relative_l1_error(scene, exact);
    return m;
}

}  // namespace

TEST_CASE("estimated_relative_l1: half the halves' difference over the mean", "[render][progressive]") {
    render::Image a(2, 1), b(2, 1);
    a.rgb = {1, 1, 1, 2, 2, 2};
    b.rgb = {3, 3, 3, 2, 2, 2};
    // |a - b| sums to 6, the mean (2 everywhere) to 12: 6 / (2 * 12).
    CHECK(render::estimated_relative_l1(a, b) == Approx(0.25));
    CHECK(render::estimated_relative_l1(a, a) == 0.0);
    render::Image zero(2, 1);
    CHECK(render::estimated_relative_l1(zero, zero) == 0.0);
}

TEST_CASE("estimate_error: noise, bias and both, against the error they make", "[render][progressive][bias]") {
    // Halves a = truth + bias + noise_a, b likewise, and bias images = bias + their own
    // noise (as the final gather's are: unbiased, noisier than the image). The estimate
    // is held against the mean's true relative L1 error.
    constexpr int W = 96, H = 96;
    sampling::Rng rng(17, 3);
    auto normal = [&rng] {
        const double u1 = std::max(rng.uniform(), 1e-300), u2 = rng.uniform();
        return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
    };
    struct Case {
        const char* name;
        double noise, bias, bias_noise;
    };
    for (const Case c : {Case{"noise alone", 0.02, 0.0, 0.1}, Case{"bias alone", 0.0005, 0.05, 0.1},
                         Case{"both", 0.02, 0.03, 0.1}, Case{"noise, no bias image", 0.02, 0.0, -1.0}}) {
        render::Image a(W, H), b(W, H), ba(W, H), bb(W, H), truth(W, H), mean(W, H);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                for (int k = 0; k < 3; ++k) {
                    // A bright corner too bright, a band too dark, the rest right.
                    const double level = 1.0 + 0.5 * k, bias = x < 32 && y < 32 ? c.bias : (y > 64 ? -c.bias / 2 : 0.0);
                    truth.at(x, y)[k] = static_cast<float>(level);
                    a.at(x, y)[k] = static_cast<float>(level + bias + c.noise * normal());
                    b.at(x, y)[k] = static_cast<float>(level + bias + c.noise * normal());
                    mean.at(x, y)[k] = 0.5f * (a.at(x, y)[k] + b.at(x, y)[k]);
                    ba.at(x, y)[k] = static_cast<float>(bias + std::max(c.bias_noise, 0.0) * normal());
                    bb.at(x, y)[k] = static_cast<float>(bias + std::max(c.bias_noise, 0.0) * normal());
                }
        const double error = render::relative_l1(mean, truth);
        const auto e = c.bias_noise < 0.0 ? render::estimate_error(a, b, {}, {}) : render::estimate_error(a, b, ba, bb);
        INFO(c.name << ": true error " << error << ", estimated " << e.total << " (noise " << e.noise << ", bias "
                    << e.bias << ")");
        CHECK(e.total == Approx(error).epsilon(0.15));
        // The noise part is the halves' rule, over the truth's estimated sum.
        CHECK(e.noise == Approx(render::estimated_relative_l1(a, b)).epsilon(0.02));
        // Noise in the bias images makes some blocks' bias look nonzero: little, next to
        // the image's noise.
        if (c.bias == 0.0) CHECK(e.bias <= 0.5 * e.noise);
        if (c.bias_noise < 0.0) CHECK(e.total == e.noise);
        // The bias the halves share, as a root mean square over the mean |truth|: the
        // corner's c.bias on 1024 of the 9216 pixels and the band's c.bias / 2 on 2976 of
        // them, over a mean of 1.5, is 0.292 c.bias; less twice its standard error.
        INFO("shared bias " << e.shared << ", exact " << 0.292 * c.bias);
        if (c.bias_noise >= 0.0) {
            CHECK(e.shared <= 0.292 * c.bias + 0.001);
            CHECK(e.shared >= 0.8 * 0.292 * c.bias);
        }
    }
    CHECK_THROWS_AS(render::estimate_error(render::Image(2, 2), render::Image(2, 2), render::Image(2, 1),
                                           render::Image(2, 1)),
                    std::invalid_argument);
    CHECK_THROWS_AS(render::estimate_error(render::Image(2, 2), render::Image(2, 2), render::Image(2, 2),
                                           render::Image(2, 2), 1),
                    std::invalid_argument);
    // A size that is no multiple of the block (a corner block of one pixel): the noise
    // of the bias images alone makes no error.
    render::Image a(17, 17), ba(17, 17), bb(17, 17);
    a.rgb.assign(a.rgb.size(), 1.0f);
    for (std::size_t k = 0; k < ba.rgb.size(); ++k) {
        ba.rgb[k] = static_cast<float>(0.1 * normal());
        bb.rgb[k] = static_cast<float>(0.1 * normal());
    }
    const auto e = render::estimate_error(a, a, ba, bb);
    INFO("noise of the bias images alone: estimated " << e.total);
    CHECK(e.noise == 0.0);
    CHECK(e.total < 0.02);
}

namespace {

// Each configuration's true error (the image's and the field's relative L1 against the
// exact radiance the method converges to) and its estimate, both averaged over twenty
// seeds: on this box the final gather's error is mostly one number, the level of the
// whole field, so a single run's |error| and estimate are each as spread as |N(0, 1)|,
// and only their expectations can be compared.
struct EstimateCase {
    const char* name;
    const char* method;
    bool unbiased, gather, diffuse_shot;
    long steps;
    int gather_rays, spp;
};

void check_estimates(const EstimateCase& c) {
    constexpr int kSeeds = 20;
    solver::SolverOptions so;
    so.method = c.method;
    so.unbiased = c.unbiased;
    if (std::string(c.method) != "iteration") so.depth = 4;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    io.steps = c.steps;
    io.gather = c.gather;
    io.gather_options.gather_rays = c.gather_rays;
    io.gather_options.spp = c.spp;
    io.gather_options.direct_samples = 4;
    double image = 0.0, image_estimate = 0.0, field = 0.0, field_estimate = 0.0;
    for (std::uint64_t seed = 1; seed <= kSeeds; ++seed) {
        const auto m = homogeneous(so, io, {}, seed, c.diffuse_shot);
        image += m.true_image_error;
        image_estimate += m.image.rounds.estimate;
        field += m.true_field_error;
        field_estimate += m.image.field_estimate;
    }
    INFO(c.name << ", means of " << kSeeds << " seeds: image error " << image / kSeeds << ", estimated "
                << image_estimate / kSeeds << "; field error " << field / kSeeds << ", estimated "
                << field_estimate / kSeeds);
    CHECK(image_estimate / image > 0.5);
    CHECK(image_estimate / image < 2.0);
    CHECK(field_estimate / field > 0.5);
    CHECK(field_estimate / field < 2.0);
}

}  // namespace

// Three test cases of two configurations each, not one of six: each takes a minute or
// two under the sanitizers, where one limit holds per test.
TEST_CASE("error estimate: within a factor 2 of the true error, iteration and the final gather",
          "[render][progressive]") {
    check_estimates({"iteration, final gather", "iteration", false, true, false, 200, 8, 2});
    check_estimates({"iteration, final gather, more", "iteration", false, true, false, 1000, 32, 8});
}

TEST_CASE("error estimate: within a factor 2 of the true error, the diffuse shot and walks with the final gather",
          "[render][progressive]") {
    check_estimates({"iteration, diffuse shot, final gather", "iteration", false, true, true, 400, 16, 4});
    check_estimates({"unbiased bidirectional walks, final gather", "bidirectional", true, true, false, 100, 16, 4});
}

TEST_CASE("error estimate: within a factor 2 of the true error, the patch images", "[render][progressive]") {
    check_estimates({"iteration, patch image", "iteration", false, false, false, 100, 1, 1});
    check_estimates({"truncated walks, patch image", "walk", false, false, false, 400, 1, 1});
}

TEST_CASE("error estimate: the path tracer's halves on the homogeneous box", "[render][progressive][pathtrace]") {
    auto scene = scenes::make_builtin("homogeneous-box", 0.25);
    scene.camera.width = scene.camera.height = 32;
    const scenes::RayCaster caster(scene);
    render::PathTraceOptions o;
    for (int spp : {4, 64}) {
        o.spp = spp;
        sampling::RunOptions run;
        run.threads = 2;
        const auto traced = render::traced_image(scene, caster, render::PinholeCamera(scene.camera), o, {}, run);
        render::Image one(32, 32);
        one.rgb.assign(one.rgb.size(), 1.0f);
        const double truth = render::relative_l1(traced.traced.image, one);
        INFO(spp << " paths: error " << truth << ", estimated " << traced.rounds.estimate);
        CHECK(traced.traced.paths == 32L * 32 * spp);
        CHECK(traced.rounds.estimate / truth > 0.5);
        CHECK(traced.rounds.estimate / truth < 2.0);
    }
}

TEST_CASE("target error: rounds until the estimate is below it, and the truth follows", "[render][progressive]") {
    solver::SolverOptions so;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    io.steps = 200;
    io.gather_options.gather_rays = 16;
    io.gather_options.spp = 4;
    io.gather_options.direct_samples = 2;
    render::RoundOptions ro;
    ro.target_error = 0.0015;
    const auto m = homogeneous(so, io, ro, 3);
    const auto& r = m.image.rounds;
    INFO("rounds " << r.rounds.size() << ", scale " << r.scale << ", estimate " << r.estimate << ", true error "
                   << m.true_image_error << ", stopped: " << r.stopped);
    CHECK(r.rounds.size() >= 2);
    CHECK(r.rounds.front().scale == 0.25);
    CHECK(r.estimate <= ro.target_error);
    CHECK(r.stopped == "the estimate reached the target");
    CHECK(m.true_image_error < 3.0 * ro.target_error);
    // Each round's estimate is the estimate of all rounds so far: it falls.
    CHECK(r.rounds.back().estimate < r.rounds.front().estimate);
    // The rounds' scales add up to the budget used.
    double total = 0.0;
    for (const auto& k : r.rounds) total += k.scale;
    CHECK(total == Approx(r.scale));
}

TEST_CASE("time budget: rounds until it is spent, at least one", "[render][progressive]") {
    solver::SolverOptions so;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    io.steps = 40;
    io.gather_options.gather_rays = 4;
    io.gather_options.spp = 1;
    io.gather_options.direct_samples = 1;
    render::RoundOptions ro;
    ro.time_budget = 1e-9;  // spent by the first round
    auto m = homogeneous(so, io, ro, 4);
    CHECK(m.image.rounds.rounds.size() == 1);
    CHECK(m.image.rounds.stopped == "the time budget");
    // Its steps cut to the quarter that is timed (the scale's 1/4 of a round of 1/4):
    // slow steps do not make a first round that overruns the budget.
    CHECK(m.image.rounds.rounds[0].steps == Approx(0.0625));
    // A budget of 4 such rounds (a multiple of the time measured here, not seconds: a
    // sanitizer build is several times slower).
    ro.time_budget = std::max(0.5, 4.0 * m.image.rounds.rounds.back().seconds);
    m = homogeneous(so, io, ro, 4);
    INFO("rounds " << m.image.rounds.rounds.size() << ", last ended at " << m.image.rounds.rounds.back().seconds);
    CHECK(m.image.rounds.rounds.size() >= 2);
    CHECK(m.image.rounds.stopped == "the time budget");
}

TEST_CASE("rounds: the same seed gives the same image, for any thread count", "[render][progressive]") {
    solver::SolverOptions so;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    io.steps = 100;
    io.gather_options.gather_rays = 8;
    io.gather_options.spp = 4;
    render::RoundOptions ro;
    ro.target_error = 0.01;
    const auto a = homogeneous(so, io, ro, 5, false, 1);
    const auto b = homogeneous(so, io, ro, 5, false, 3);
    const auto c = homogeneous(so, io, ro, 6, false, 2);
    CHECK(a.image.image.rgb == b.image.image.rgb);
    CHECK(a.image.rounds.rounds.size() == b.image.rounds.rounds.size());
    CHECK(a.image.image.rgb != c.image.image.rgb);
    // The correction "auto" decides from the images alone (not the seconds) without a
    // time budget.
    io.auto_correction = true;
    const auto d = homogeneous(so, io, ro, 5, false, 1);
    const auto e = homogeneous(so, io, ro, 5, false, 3);
    CHECK(d.image.image.rgb == e.image.image.rgb);
    CHECK(d.image.rounds.correction == e.image.rounds.correction);
    CHECK(d.image.rounds.rounds.size() == e.image.rounds.rounds.size());
}

TEST_CASE("rounds: bad options are refused by name", "[render][progressive]") {
    solver::SolverOptions so;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    render::RoundOptions ro;
    ro.target_error = -1.0;
    CHECK_THROWS_WITH(homogeneous(so, io, ro, 1), Catch::Contains("must be a finite number >= 0"));
    ro.target_error = 0.0;
    ro.time_budget = std::nan("");
    CHECK_THROWS_WITH(homogeneous(so, io, ro, 1), Catch::Contains("must be a finite number >= 0"));
}

TEST_CASE("rounds: the steps' share follows where the noise is", "[render][progressive]") {
    // The probe of the first rounds splits the estimate into the field's part and the
    // samples': few steps and many samples give the solve more of the later rounds;
    // many steps and few samples give it less. The field is read as the answer
    // (correction 0): with GatherOptions::correction its noise would enter each gather
    // ray with a weight of mean zero, and little of the estimate would be the field's.
    solver::SolverOptions so;
    render::RoundOptions ro;
    ro.target_error = 0.002;
    ro.time_budget = 3.0;
    render::FieldImageOptions io;
    io.gather_options = guide_only_gather();
    io.gather_options.correction = 0.0;
    io.steps = 20;
    io.gather_options.gather_rays = 64;
    io.gather_options.spp = 16;
    auto m = homogeneous(so, io, ro, 7);
    INFO("few steps: field share " << m.image.rounds.field_share << ", steps share " << m.image.rounds.steps_share);
    CHECK(m.image.rounds.field_share > 0.7);
    CHECK(m.image.rounds.steps_share > 1.5);
    io.steps = 4000;
    io.gather_options.gather_rays = 1;
    io.gather_options.spp = 2;
    io.gather_options.direct_samples = 1;
    io.gather_options.filter.filter = render::Filter::none;
    m = homogeneous(so, io, ro, 7);
    INFO("many steps: field share " << m.image.rounds.field_share << ", steps share " << m.image.rounds.steps_share);
    CHECK(m.image.rounds.field_share < 0.5);
    CHECK(m.image.rounds.steps_share < 0.7);
    // A run without a target or a time budget does not probe.
    m = homogeneous(so, io, {}, 7);
    CHECK(m.image.rounds.field_share < 0.0);
    CHECK(m.image.rounds.steps_share == 1.0);
}

namespace {

// A chain whose field is the same at every step: here a wrong one.
class FixedChain : public render::FieldChain {
public:
    explicit FixedChain(solver::RadianceField field) : field_(std::move(field)) {}
    void advance(long steps, const sampling::ProgressCallback&) override { steps_ += steps; }
    solver::RadianceField field(int /*threads*/ = 0) const override { return field_; }
    long averaged() const override { return steps_; }

private:
    solver::RadianceField field_;
    long steps_ = 0;
};

// The homogeneous box at 32x32 (1 everywhere) made in rounds from chains whose field
// is 0.7 everywhere, with `rays` gather rays and `spp` camera and light samples.
struct WrongFieldBox {
    scenes::Scene scene;
    scenes::RayCaster caster;
    solver::RadianceField field;
    render::FieldImageOptions io;
    WrongFieldBox(int rays, int spp) : scene(box(32)), caster(scene) {
        field.radiance.assign(scene.patch_list().size(), scenes::Rgb::Constant(0.7));
        io.gather_options = guide_only_gather();
        io.steps = 10;
        io.gather_options.gather_rays = rays;
        io.gather_options.spp = spp;
        io.gather_options.direct_samples = spp;
    }
    static scenes::Scene box(int size) {
        auto s = scenes::make_builtin("homogeneous-box", 0.25);
        s.camera.width = s.camera.height = size;
        return s;
    }
    render::FieldImage made(const render::RoundOptions& ro, const sampling::RunOptions& run) const {
        FixedChain a(field), b(field);
        return render::field_image(scene, caster, render::PinholeCamera(scene.camera), a, b, io, ro, run);
    }
};

}  // namespace

TEST_CASE("error estimate: a run whose field is wrong sees its bias", "[render][progressive][bias]") {
    // Both chains hold a field of 0.7 on the homogeneous box (the truth is 1): the
    // halves agree, and the image is about 14 % too dark. The estimate sees that with
    // the bias probe (its default), and only its noise without it.
    WrongFieldBox box(64, 4);
    sampling::RunOptions run;
    run.threads = 2;
    run.seed = 3;
    render::Image one(32, 32);
    one.rgb.assign(one.rgb.size(), 1.0f);
    for (const double probe : {render::GatherOptions{}.bias_probe, 0.0}) {
        box.io.gather_options.bias_probe = probe;
        const auto made = box.made({}, run);
        const double error = render::relative_l1(made.image, one);
        const auto& e = made.rounds.parts;
        INFO("probe " << probe << ": true error " << error << ", estimated " << e.total << " (noise " << e.noise
                      << ", bias " << e.bias << ")");
        CHECK(error > 0.1);
        CHECK(made.rounds.estimate == e.total);
        if (probe > 0.0) {
            CHECK(e.total == Approx(error).epsilon(0.1));
            CHECK(e.bias > 0.75 * error);
            CHECK(made.gather->bias_rays > 0);
        } else {
            CHECK(e.total < 0.2 * error);
        }
    }
}

TEST_CASE("target error: a bias above the target stops the rounds, named", "[render][progressive][bias]") {
    // The field of 0.7 on the homogeneous box again (about 14 % off): no round lowers
    // that, and a target of 5 % stops once two rounds in a row find the bias where it
    // was at half the budget, not after 1024 times the options' budget.
    const WrongFieldBox box(16, 2);
    render::RoundOptions ro;
    ro.target_error = 0.05;
    sampling::RunOptions run;
    run.threads = 2;
    const auto made = box.made(ro, run);
    const auto& r = made.rounds;
    INFO("rounds " << r.rounds.size() << ", scale " << r.scale << ", estimate " << r.estimate << " (bias "
                   << r.parts.bias << "), stopped: " << r.stopped);
    CHECK(r.stopped == "the probed error, a bias, is at the target or above: more rounds do not lower it");
    CHECK(r.rounds.size() >= 3);
    CHECK(r.scale < 64.0);
    CHECK(r.parts.bias > 0.1);
    // The rounds were averaged with their scales: the estimate is still the error.
    render::Image one(32, 32);
    one.rgb.assign(one.rgb.size(), 1.0f);
    CHECK(r.estimate == Approx(render::relative_l1(made.image, one)).epsilon(0.1));
}

TEST_CASE("choose_correction: the correction where the bias outlasts the noise", "[render][progressive][correction]") {
    render::CorrectionInputs in;
    in.probe = 1.0 / 16.0;
    in.noise = 0.02;
    in.corrected_noise = 0.04;  // the probe's corrections add sqrt(0.04^2 - 0.02^2) = 3.5 % at P
    in.scale = 1.0;
    in.more = 15.0;
    in.probe_cost = 0.1;
    SECTION("no bias, corrections noisier than the tolerance allows: go on reading the field") {
        const auto plan = render::choose_correction(in);
        CHECK(plan.q == 0.0);
        CHECK(plan.reading == Approx(0.02 / 4.0));
        CHECK(plan.predicted == plan.reading);
    }
    SECTION("a bias above what the noise will be: correct, with its predicted error") {
        in.bias = 0.02;
        const auto plan = render::choose_correction(in);
        CHECK(plan.q > 0.0);
        CHECK(plan.reading == Approx(std::sqrt(0.02 * 0.02 + 0.02 * 0.02 / 16.0)));
        CHECK(plan.predicted < plan.reading);
        // The formula of the header at the q chosen.
        const double x = in.more / (1.0 + in.probe_cost * (plan.q / in.probe - 1.0)), c2 = 0.04 * 0.04 - 0.02 * 0.02;
        CHECK(plan.predicted ==
              Approx(std::sqrt(0.02 * 0.02 / (1.0 + x) + c2 * (1.0 + x * in.probe / plan.q) / ((1.0 + x) * (1.0 + x)))));
    }
    SECTION("nothing to come: the rounds end as they are") {
        in.bias = 0.02;
        in.more = 0.0;
        CHECK(render::choose_correction(in).q == 0.0);
    }
    SECTION("a bias the filter makes too: the correction does not remove it, and costs") {
        in.bias = 0.02;
        in.corrected_bias = 0.02;
        in.tolerance = 0.0;
        CHECK(render::choose_correction(in).q == 0.0);
    }
    SECTION("no bias seen, a cheap correction: taken within the tolerance, not beyond it") {
        in.corrected_noise = 0.0201;
        const auto plan = render::choose_correction(in);
        CHECK(plan.q > 0.0);
        CHECK(plan.predicted > plan.reading);
        CHECK(plan.predicted <= 1.25 * plan.reading);
        in.tolerance = 0.0;
        CHECK(render::choose_correction(in).q == 0.0);
    }
    SECTION("corrections far noisier than the bias: go on reading the field") {
        in.bias = 0.003;
        in.corrected_noise = 0.5;
        CHECK(render::choose_correction(in).q == 0.0);
    }
    SECTION("never below the probe's rate, nothing without a probe or a budget") {
        in.bias = 0.05;
        in.probe = 0.3;
        CHECK(render::choose_correction(in).q >= 0.3);
        in.probe = 0.0;
        CHECK(render::choose_correction(in).q == 0.0);
        in.probe = 0.3;
        in.scale = 0.0;
        CHECK(render::choose_correction(in).q == 0.0);
    }
}

TEST_CASE("correction auto: a wrong field's image converges to the truth", "[render][progressive][correction]") {
    // The field of 0.7 on the homogeneous box (the image about 14 % dark when it is read
    // as the answer). With the correction "auto", one round shows the probe's corrected
    // image (the bias stands far above its noise); a target of 3 % switches the rounds to the
    // correction, reaches it, and the truth follows.
    sampling::RunOptions run;
    run.threads = 2;
    run.seed = 5;
    render::Image one(32, 32);
    one.rgb.assign(one.rgb.size(), 1.0f);
    WrongFieldBox box(64, 4);
    box.io.auto_correction = true;
    const auto once = box.made({}, run);
    INFO("one round: error " << render::relative_l1(once.image, one) << ", estimate " << once.rounds.estimate << ", "
                             << once.rounds.correction_choice);
    CHECK(once.rounds.corrected);
    CHECK(once.rounds.correction == 0.0);
    CHECK(render::relative_l1(once.image, one) < 0.06);
    CHECK(once.rounds.estimate == Approx(render::relative_l1(once.image, one)).epsilon(0.5));

    render::RoundOptions ro;
    ro.target_error = 0.03;
    WrongFieldBox small(16, 2);
    small.io.auto_correction = true;
    const auto made = small.made(ro, run);
    const auto& r = made.rounds;
    const double error = render::relative_l1(made.image, one);
    INFO("target: rounds " << r.rounds.size() << ", q " << r.correction << ", estimate " << r.estimate << ", error "
                           << error << ", stopped: " << r.stopped << "; " << r.correction_choice);
    CHECK(r.correction > 0.0);
    CHECK(r.corrected);
    CHECK(r.stopped == "the estimate reached the target");
    CHECK(error < 1.5 * ro.target_error);
    CHECK(r.rounds.front().correction == 0.0);
    CHECK(r.rounds.back().correction == r.correction);
    // Without auto the same run stops at the bias (the test above).
    small.io.auto_correction = false;
    CHECK(small.made(ro, run).rounds.stopped ==
          "the probed error, a bias, is at the target or above: more rounds do not lower it");
}

TEST_CASE("correction auto: a right field is read as the answer", "[render][progressive][correction]") {
    // The exact field (1 everywhere): nothing to correct, and the corrections' noise
    // would only add to the image's, so the rounds read the field.
    sampling::RunOptions run;
    run.threads = 2;
    run.seed = 7;
    WrongFieldBox box(16, 2);
    box.field.radiance.assign(box.scene.patch_list().size(), scenes::Rgb::Constant(1.0));
    box.io.auto_correction = true;
    render::RoundOptions ro;
    ro.target_error = 0.001;
    const auto made = box.made(ro, run);
    const auto& r = made.rounds;
    INFO("rounds " << r.rounds.size() << ", estimate " << r.estimate << ", stopped: " << r.stopped << "; "
                   << r.correction_choice);
    CHECK(r.rounds.size() >= 2);
    CHECK(r.correction == 0.0);
    CHECK(!r.corrected);
    CHECK(r.stopped == "the estimate reached the target");
}
