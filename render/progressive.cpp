#include "render/progressive.h"

#include "render/gbuffer.h"
#include "sampling/streams.h"
#include "scenes/errors.h"
#include "scenes/threads.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

namespace raybundle::render {

using scenes::Rgb;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// dst += w src (dst empty: w src).
// Each value on its own: bands of rows on the threads, the same for any count.
void add_scaled(Image& dst, const Image& src, double w, int threads) {
    const bool first = dst.rgb.empty();  // then the threads write it first (0 + x is x)
    if (first) dst = Image(src.width, src.height, Image::Unfilled{});
    const std::size_t row = 3 * static_cast<std::size_t>(src.width);
    parallel_bands(src.height, threads, [&](int y0, int y1) {
        for (std::size_t k = row * static_cast<std::size_t>(y0); k < row * static_cast<std::size_t>(y1); ++k)
            dst.rgb[k] = (first ? 0.0f : dst.rgb[k]) + static_cast<float>(w * src.rgb[k]);
    });
}

Image scaled(const Image& a, double s, int threads) {
    Image out(a.width, a.height, Image::Unfilled{});
    const std::size_t row = 3 * static_cast<std::size_t>(a.width);
    parallel_bands(a.height, threads, [&](int y0, int y1) {
        for (std::size_t k = row * static_cast<std::size_t>(y0); k < row * static_cast<std::size_t>(y1); ++k)
            out.rgb[k] = static_cast<float>(s * a.rgb[k]);
    });
    return out;
}

// A round of scale r gives each half r * total / 2 units, rounded, at least `least`,
// at most 2^30.
long half_of(long total, double scale, long least = 1) {
    const double half = std::min(scale * static_cast<double>(total) / 2.0, 1073741824.0);
    return std::max(least, static_cast<long>(std::llround(half)));
}

// A target alone stops at this many times the options' budget.
constexpr double kMostScale = 1024.0;

double first_scale(const RoundOptions& o) { return o.target_error > 0.0 || o.time_budget > 0.0 ? 0.25 : 1.0; }

void check(const RoundOptions& o) {
    if (!(o.target_error >= 0.0) || !std::isfinite(o.target_error))
        throw scenes::OptionError("target_error", "must be a finite number >= 0, got " + std::to_string(o.target_error));
    if (!(o.time_budget >= 0.0) || !std::isfinite(o.time_budget))
        throw scenes::OptionError("time_budget", "must be a finite number >= 0, got " + std::to_string(o.time_budget));
}

// Progress of half h's pass, as part of the round's two: done and total doubled.
sampling::RunOptions half_run(const sampling::RunOptions& run, int h) {
    sampling::RunOptions r = run;
    if (run.progress)
        r.progress = [h, &run](const sampling::Progress& p) {
            sampling::Progress q = p;
            q.done = h * p.total + p.done;
            q.total = 2 * p.total;
            run.progress(q);
        };
    return r;
}

// The share of the steps: in the first two rounds of a run with a target or a time
// budget, a probe renders half A's pass again, the same samples, from chain B's
// field; the two differ by the field's noise alone (its part of the round's
// estimate, e_f), the rest (e_r) is the camera, light and gather samples'. A pass of
// steps scale s and scale r has the squared error F / s + G / r, F = e_f^2 s and
// G = e_r^2 r from the latest probed round, and the passes' weighted mean (weights
// r_k)
//
//   F sum_k r_k^2 / s_k / (sum_k r_k)^2 + G / sum_k r_k.
//
// With t_s and t_g the seconds per unit of steps and of scale, the error of a given
// time is least with steps / scale = sqrt(F t_g / (G t_s)) (clamped to 1/8 .. 8):
// later rounds take that share. That needs the seconds, which vary from run to run; a
// run with a target and no time budget takes t_g = t_s instead (the options' budget
// splits its time about evenly between the two on the example scenes), so that its
// rounds, and its image, depend on the seed alone. The model, scaled to the last
// estimate, sizes the rounds for a target (the smallest round that reaches it, found
// on a geometric grid: the model need not fall monotonically when the share changes).
// The probe is timed apart. The patch image has no probe: its noise is the field's.
struct Shape {
    double steps = 1.0;   // steps per unit of scale, relative to the options'
    double field = -1.0;  // e_f / e_total of the latest probed round (negative: not probed)
};

// One half's pass: its image and, from the final gather, its bias image (else empty);
// with the bias probe, the image as the probe's corrections make it and its bias image,
// and the probe's share of the pass's rays (else empty, 0).
struct Pass {
    Image image, bias, corrected, corrected_bias;
    double probe_share = 0.0;
    explicit Pass(Image i, Image b = Image()) : image(std::move(i)), bias(std::move(b)) {}
};

// The correction "auto" for run_rounds: on, and the probe's rate.
struct AutoCorrection {
    bool on = false;
    double probe = 0.0;
};

// What a round's advance did: all its steps; all, and told to stop after the round;
// stopped part-way (pause), with new averaged steps in both chains, or without.
enum class Advanced { all, last, cut, nothing_new };

// The rounds (see the header): `advance(steps_scale, run)` moves the solver on,
// `render(h, scale, pass, q, run)` makes half h's Pass (q: the correction "auto"'s), `probe(scale, pass, run)` half
// A's pass from chain B's field (or nothing), `after(round, image, estimate)` sees
// each round's result. The runs passed on report progress with the round and the
// estimate.
template <class Advance, class Render, class Probe, class After>
Rounds run_rounds(const RoundOptions& o, const sampling::RunOptions& run, Advance advance, Render render, Probe probe,
                  After after, const AutoCorrection& automatic = {}) {
    check(o);
    Rounds out;
    // Per half: sums over rounds of scale * pass, as read (U) and corrected (C: the
    // probe's corrections added where a round has them; the same as U where not).
    Image sum[2], bias_sum[2], csum[2], cbias_sum[2];
    double q = 0.0;            // the correction the rounds run with
    bool use_corrected = false;
    double probe_share = 0.0;  // the latest probed pass's
    double render_since = 0.0, scale_since = 0.0;  // render seconds and scale since q last changed
    double estimate = -1.0;
    long round = 0;
    sampling::RunOptions inner = run;
    if (run.progress)
        inner.progress = [&](const sampling::Progress& p) {
            sampling::Progress shown = p;
            shown.round = round;
            shown.estimate = estimate;
            run.progress(shown);
        };
    const bool target = o.target_error > 0.0, timed = o.time_budget > 0.0;
    Shape shape;
    int bias_floors = 0;  // rounds in a row that found a bias at the target or above
    double F = 0.0, G = 0.0, field_sum = 0.0;  // field_sum: sum_k r_k^2 / s_k
    double steps_total = 0.0;
    const auto start = Clock::now();
    for (double scale = first_scale(o);;) {
        ++round;
        double steps = scale * shape.steps;
        const auto t0 = Clock::now();
        Advanced advanced = Advanced::all;
        if (timed && round == 1) {
            // A time budget's first round: a quarter of its steps (more than the burn-in,
            // which is at most a tenth of them), timed, then what fits in an eighth of
            // the budget, up to the rest. Steps that are slow (a dense mesh) give fewer
            // steps, not a first round that overruns the budget.
            const double part = steps / 4.0;
            advanced = advance(part, inner);
            const double took = since(t0);
            double more = steps - part;
            if (advanced == Advanced::all && took > 0.0)
                more = std::clamp((o.time_budget / 8.0 - took) / took * part, 0.0, more);
            if (advanced == Advanced::all && more >= part / 64.0)
                advanced = advance(more, inner);
            else
                more = 0.0;
            steps = part + more;
        } else {
            advanced = advance(steps, inner);
        }
        const auto t1 = Clock::now();
        if (advanced == Advanced::nothing_new) {
            if (round == 1) throw Interrupted("interrupted before any step was averaged (the burn-in): no image");
            out.seconds_solve += std::chrono::duration<double>(t1 - t0).count();
            out.stopped = "interrupted: the image of the rounds before";
            out.interrupted = true;
            break;
        }
        Image pass_image[2];
        for (int h = 0; h < 2; ++h) {
            const auto pass = static_cast<std::uint64_t>(2 * (round - 1) + h);
            Pass made = render(h, scale, pass, q, half_run(inner, h));
            if (automatic.on) {
                const bool probed_pass = !made.corrected.rgb.empty();
                add_scaled(csum[h], probed_pass ? made.corrected : made.image, scale, inner.threads);
                if (!made.bias.rgb.empty())
                    add_scaled(cbias_sum[h], probed_pass ? made.corrected_bias : made.bias, scale, inner.threads);
                if (probed_pass) probe_share = made.probe_share;
            }
            pass_image[h] = std::move(made.image);
            add_scaled(sum[h], pass_image[h], scale, inner.threads);
            if (!made.bias.rgb.empty()) add_scaled(bias_sum[h], made.bias, scale, inner.threads);
        }
        bool probed = false;
        const auto t2 = Clock::now();
        if (round <= 2 && (target || timed)) {
            sampling::RunOptions quiet = inner;
            quiet.progress = nullptr;
            const Image p = probe(scale, static_cast<std::uint64_t>(2 * (round - 1)), quiet);
            if (!p.rgb.empty()) {
                const double total = estimated_relative_l1(pass_image[0], pass_image[1]);
                const double e_f = estimated_relative_l1(p, pass_image[0]);
                const double e_r2 = std::max(total * total - e_f * e_f, 0.01 * total * total);
                F = e_f * e_f * steps;
                G = e_r2 * scale;
                shape.field = total > 0.0 ? e_f / total : 0.0;
                probed = true;
            }
        }
        out.seconds_solve += std::chrono::duration<double>(t1 - t0).count();
        out.seconds_render += std::chrono::duration<double>(t2 - t1).count();
        render_since += std::chrono::duration<double>(t2 - t1).count();
        scale_since += scale;
        const double probe_seconds = since(t2);
        out.seconds_probe += probe_seconds;
        out.scale += scale;
        steps_total += steps;
        field_sum += scale * scale / steps;
        // Both halves' means so far, and their estimate.
        auto estimated = [&](const Image (&s)[2], const Image (&bs)[2]) {
            std::pair<Image, Image> halves{scaled(s[0], 1.0 / out.scale, inner.threads), scaled(s[1], 1.0 / out.scale, inner.threads)};
            const ErrorEstimate e =
                bs[0].rgb.empty() || bs[1].rgb.empty()
                    ? estimate_error(halves.first, halves.second, Image(), Image())
                    : estimate_error(halves.first, halves.second, scaled(bs[0], 1.0 / out.scale, inner.threads),
                                     scaled(bs[1], 1.0 / out.scale, inner.threads));
            return std::pair{std::move(halves), e};
        };
        auto [halves, parts] = estimated(sum, bias_sum);
        // The correction "auto": C or U (always C once the rounds correct); the figures
        // of both kept for the choice of q below.
        CorrectionInputs weighed;
        double corrected_noise = -1.0;
        const bool weigh = automatic.on && q == 0.0 && !csum[0].rgb.empty() && probe_share > 0.0;
        if (automatic.on && !csum[0].rgb.empty()) {
            auto [chalves, cparts] = estimated(csum, cbias_sum);
            if (q == 0.0) corrected_noise = cparts.noise;
            if (weigh) {
                weighed.probe = automatic.probe;
                weighed.noise = parts.noise;
                weighed.bias = parts.shared;
                weighed.corrected_noise = cparts.noise;
                weighed.corrected_bias = cparts.shared;
                weighed.scale = out.scale;
            }
            // While the rounds read the field, the probe's corrected image is shown when
            // the field's part of the bias both halves share (U's less C's, the filter's,
            // which stays in both) stands above the noise its corrections add. The
            // estimates alone would weigh that noise by the pixel, where the filter has
            // spread it over blocks (a 512^2 Cornell box: 0.53 % read, 0.75 % corrected
            // on 128^2 means).
            const double added = std::sqrt(std::max(0.0, cparts.noise * cparts.noise - parts.noise * parts.noise));
            const double field_bias = std::sqrt(std::max(0.0, parts.shared * parts.shared - cparts.shared * cparts.shared));
            use_corrected = q > 0.0 || field_bias > added;
            if (use_corrected) {
                halves = std::move(chalves);
                parts = cparts;
            }
        }
        const Image& a = halves.first;
        const Image& b = halves.second;
        estimate = parts.total;
        Image mean = a;
        for (std::size_t k = 0; k < mean.rgb.size(); ++k) mean.rgb[k] = 0.5f * (a.rgb[k] + b.rgb[k]);
        const double spent = since(start);
        out.rounds.push_back({scale, q, use_corrected, corrected_noise, {}, steps, spent, estimate, parts});
        out.estimate = estimate;
        out.parts = parts;
        after(round, mean, estimate, spent);

        // The next round, or why there is none.
        if (advanced == Advanced::cut || (advanced == Advanced::last && (target || timed))) {
            out.stopped = "interrupted: the image of the steps done";
            out.interrupted = true;
            break;
        }
        if (!target && !timed) {
            out.stopped = "one round: the budget as given";
            break;
        }
        if (target && estimate <= o.target_error) {
            out.stopped = "the estimate reached the target";
            break;
        }
        // A bias at the target or above: the probed error of the latest round at most
        // half the budget so far, where it was the field's noise, was sqrt 2 times larger
        // at least. One round's bias is noisy itself: two rounds in a row must find it
        // fell by less than a tenth.
        bool floor = false;
        if (target && parts.bias >= o.target_error) {
            double before = 0.0;
            const Round* half = nullptr;
            for (const Round& k : out.rounds) {
                before += k.scale;
                if (before <= out.scale / 2.0) half = &k;
            }
            floor = half && parts.bias > 0.9 * half->parts.bias;
        }
        bias_floors = floor ? bias_floors + 1 : 0;
        if (bias_floors >= 2) {
            out.stopped = "the probed error, a bias, is at the target or above: more rounds do not lower it";
            break;
        }
        if (estimate <= 0.0) {
            out.stopped = "the halves agree exactly: nothing left to average";
            break;
        }
        if (2 * static_cast<std::uint64_t>(round) + 2 > sampling::streams::kMaxPasses) {
            out.stopped = "the most rounds a run has streams for";
            break;
        }
        // Render seconds per unit of scale at the correction the rounds now run with.
        const double t_s = out.seconds_solve / steps_total, t_g = render_since / scale_since;
        if (probed && G > 0.0 && t_s > 0.0 && t_g > 0.0)
            shape.steps = std::clamp(std::sqrt(F / G * (timed ? t_g / t_s : 1.0)), 0.125, 8.0);
        // The squared error after a further round of scale x, by the model of the noise,
        // calibrated to the estimate now (a bias that does not fall makes the rounds
        // smaller than they need be, and the rule above stops them).
        auto model = [&](double x) {
            return F * (field_sum + x / shape.steps) / std::pow(out.scale + x, 2) + G / (out.scale + x);
        };
        const double calibrate = shape.field >= 0.0 && model(0.0) > 0.0 ? estimate * estimate / model(0.0) : 0.0;
        double next = 8.0 * out.scale;
        if (target) {
            const double want = std::pow(o.target_error / 1.05, 2);
            if (calibrate > 0.0) {
                // The smallest of 64 round sizes from an eighth to 8 times the scale so far
                // whose model reaches the target, else the largest.
                for (int i = 0; i <= 64; ++i) {
                    const double x = out.scale / 8.0 * std::pow(64.0, i / 64.0);
                    if (calibrate * model(x) <= want || i == 64) {
                        next = x;
                        break;
                    }
                }
            } else {
                const double ratio = estimate / o.target_error;
                next = std::clamp(out.scale * (1.1 * ratio * ratio - 1.0), out.scale / 8.0, next);
            }
            if (!timed && out.scale >= kMostScale) {
                out.stopped = "the most a target may take (1024 times the options' budget), before the target";
                break;
            }
            if (!timed) next = std::min(next, std::max(kMostScale - out.scale, out.scale / 8.0));
        }
        if (timed) {
            // The second round probes as the first did, at its own scale.
            const double t_p = round == 1 ? probe_seconds / scale : 0.0;
            const double fits = (o.time_budget - spent) / (t_s * shape.steps + t_g + t_p);
            if (fits < out.scale / 8.0) {
                out.stopped = target ? "the time budget, before the target" : "the time budget";
                break;
            }
            next = std::min(next, fits);
        }
        // While the correction "auto" is undecided, the rounds of a time budget at most
        // double the budget so far: more moments to decide at, each with more of the bias
        // seen. (A target's rounds stay as its model sizes them: smaller ones would meet
        // the bias stop above sooner, where the bias part is the probe's noise.)
        if (weigh && timed) next = std::min(next, out.scale);
        if (weigh) {
            // The probe's share of the rounds' cost (of the render's rays, times the
            // render's share of the time; without a time budget the seconds are not used,
            // t_g = t_s as for the shape, so that the choice depends on the seed alone),
            // and the budget to come at that cost: what fits in the time, else (a target
            // alone, whose end is not known) 8 times the budget so far.
            weighed.probe_cost = timed ? probe_share * t_g / (t_s * shape.steps + t_g) : probe_share / (shape.steps + 1.0);
            weighed.more = timed ? (o.time_budget - spent) / (t_s * shape.steps + t_g) : 8.0 * out.scale;
            const CorrectionPlan plan = choose_correction(weighed);
            out.rounds.back().plan = plan;
            if (plan.q > 0.0) {
                q = plan.q;
                // The rounds' render cost rises with the paths: the next round is sized
                // at the new cost, and the cost measured anew from it.
                if (timed) next /= 1.0 + weighed.probe_cost * (q / automatic.probe - 1.0);
                render_since = scale_since = 0.0;
                char line[320];
                std::snprintf(line, sizeof line,
                              "after round %ld: correcting at q = %g (predicted %.3g %% against %.3g %% reading the field; "
                              "chosen up to a quarter above it, since the corrected image converges to the scene's light "
                              "where the field keeps its bias)",
                              round, q, 100.0 * plan.predicted, 100.0 * plan.reading);
                out.correction_choice = line;
            }
        }
        scale = next;
    }
    out.steps_share = shape.steps;
    out.field_share = shape.field;
    if (automatic.on) {
        // What the image is: the last round's (a switch whose round was interrupted
        // before it ran did not happen).
        out.correction = out.rounds.empty() ? 0.0 : out.rounds.back().correction;
        out.corrected = !out.rounds.empty() && out.rounds.back().corrected;
        if (q > 0.0 && out.correction == 0.0) out.correction_choice += ", interrupted before a round ran with it";
        if (out.correction_choice.empty())
            out.correction_choice = use_corrected ? "the probe's corrections: the field's bias is above the noise they add"
                                                  : "the field read as the answer: no bias above the noise the probe's corrections add";
    }
    return out;
}

// A field of f's sizes whose entries fill(i) writes on the threads, patch by patch (the
// direct part copied from f): the threads touch the new memory first (an Rgb's
// constructor writes nothing; see scenes/buffer.h), not one thread copying it all.
template <class Fill>
solver::RadianceField filled(const solver::RadianceField& f, int threads, const Fill& fill) {
    solver::RadianceField out;
    out.radiance.resize(f.radiance.size());
    out.direct.resize(f.direct.size());
    out.corners.resize(f.corners.size());
    parallel_chunks(static_cast<int>(f.radiance.size()), threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
            fill(out, i);
            if (!out.direct.empty()) out.direct[i] = f.direct[i];
        }
    });
    return out;
}

// The field of a chain's steps between two moments: (n2 f2 - n1 f1) / (n2 - n1).
solver::RadianceField between(const solver::RadianceField& f1, long n1, const solver::RadianceField& f2, long n2,
                              int threads) {
    if (n1 <= 0 || n2 <= n1)
        return filled(f2, threads, [&](solver::RadianceField& f, std::size_t i) {
            f.radiance[i] = f2.radiance[i];
            if (!f.corners.empty()) f.corners[i] = f2.corners[i];
        });
    const double w2 = static_cast<double>(n2) / (n2 - n1), w1 = static_cast<double>(n1) / (n2 - n1);
    return filled(f2, threads, [&](solver::RadianceField& f, std::size_t i) {
        f.radiance[i] = w2 * f2.radiance[i] - w1 * f1.radiance[i];
        if (!f.corners.empty())
            for (int k = 0; k < 3; ++k) f.corners[i][k] = w2 * f2.corners[i][k] - w1 * f1.corners[i][k];
    });
}

// The mean of both chains' fields, weighted by their step counts, and its estimated
// relative L1 error over patches (area-weighted): sqrt(na nb) / (na + nb) sum |fa - fb|
// / sum |mean|, which for na = nb is the halves' rule of the header.
std::pair<solver::RadianceField, double> combine(const scenes::Scene& scene, const solver::RadianceField& fa, long na,
                                                 const solver::RadianceField& fb, long nb, int threads) {
    const double n = static_cast<double>(na + nb);
    if (n <= 0.0) return {fa, -1.0};
    const double wa = na / n, wb = nb / n;
    solver::RadianceField f = filled(fa, threads, [&](solver::RadianceField& out, std::size_t i) {
        out.radiance[i] = wa * fa.radiance[i] + wb * fb.radiance[i];
        if (!out.corners.empty())
            for (int k = 0; k < 3; ++k) out.corners[i][k] = wa * fa.corners[i][k] + wb * fb.corners[i][k];
    });
    // The sums in patch order, on one thread (the same bits for any count).
    const auto& patches = scene.patch_list();
    double diff = 0.0, total = 0.0;
    for (std::size_t i = 0; i < f.radiance.size(); ++i) {
        diff += patches[i].area * (fa.radiance[i] - fb.radiance[i]).abs().sum();
        total += patches[i].area * f.radiance[i].abs().sum();
    }
    const double estimate = total > 0.0 ? std::sqrt(wa * wb) * diff / total : 0.0;
    return {f, estimate};
}

// Adds one pass's gather result, weight w, into the run's (the AOV means over both
// halves are taken at the end).
void add_gather(GatherResult& sum, const GatherResult& pass, double w, int threads) {
    if (sum.normal.rgb.empty()) {
        sum.normal = pass.normal;
        sum.depth = pass.depth;
        sum.position = pass.position;
    }
    add_scaled(sum.direct, pass.direct, w, threads);
    add_scaled(sum.indirect, pass.indirect, w, threads);
    add_scaled(sum.indirect_filtered, pass.indirect_filtered, w, threads);
    add_scaled(sum.bias, pass.bias, w, threads);
    sum.filter_radius = pass.filter_radius;
    sum.direct_at_hits = pass.direct_at_hits;
    sum.camera_rays += pass.camera_rays;
    sum.shadow_rays += pass.shadow_rays;
    sum.gather_rays += pass.gather_rays;
    sum.bias_rays += pass.bias_rays;
    sum.lookups += pass.lookups;
    sum.lookups_across += pass.lookups_across;
    sum.seconds_guides += pass.seconds_guides;
    sum.seconds_filter += pass.seconds_filter;
    sum.seconds_samples += pass.seconds_samples;
}

}  // namespace

double estimated_relative_l1(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) throw std::invalid_argument("image sizes differ");
    double diff = 0.0, total = 0.0;
    for (std::size_t k = 0; k < a.rgb.size(); ++k) {
        diff += std::abs(static_cast<double>(a.rgb[k]) - b.rgb[k]);
        total += std::abs(0.5 * (static_cast<double>(a.rgb[k]) + b.rgb[k]));
    }
    return total > 0.0 ? 0.5 * diff / total : 0.0;
}

ErrorEstimate estimate_error(const Image& a, const Image& b, const Image& bias_a, const Image& bias_b, int block) {
    if (a.width != b.width || a.height != b.height) throw std::invalid_argument("image sizes differ");
    const bool biased = !bias_a.rgb.empty() || !bias_b.rgb.empty();
    if (biased && (bias_a.width != a.width || bias_a.height != a.height || bias_b.width != a.width ||
                   bias_b.height != a.height))
        throw std::invalid_argument("bias image sizes differ from the image's");
    if (block < 2) throw std::invalid_argument("block must be >= 2");
    const double noise = estimated_relative_l1(a, b);
    if (!biased) return {noise, noise, 0.0, 0.0, 0.0};
    // Per block and channel, sums over its pixels of the mean bias image r, of r^2, of
    // the half-difference h = (a - b) / 2, and of |h - its block mean| (a second pass).
    const int bw = (a.width + block - 1) / block, bh = (a.height + block - 1) / block;
    struct Block {
        double n = 0.0;
        Rgb r = Rgb::Zero(), r2 = Rgb::Zero(), h = Rgb::Zero(), deviation = Rgb::Zero(), ra = Rgb::Zero(),
            rb = Rgb::Zero();
    };
    std::vector<Block> blocks(static_cast<std::size_t>(bw) * bh);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            Block& B = blocks[static_cast<std::size_t>(y / block) * bw + x / block];
            B.n += 1.0;
            const float *pa = a.at(x, y), *pb = b.at(x, y), *ba = bias_a.at(x, y), *bb = bias_b.at(x, y);
            for (int c = 0; c < 3; ++c) {
                const double r = 0.5 * (static_cast<double>(ba[c]) + bb[c]), h = 0.5 * (static_cast<double>(pa[c]) - pb[c]);
                B.r[c] += r;
                B.r2[c] += r * r;
                B.ra[c] += ba[c];
                B.rb[c] += bb[c];
                B.h[c] += h;
            }
        }
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            Block& B = blocks[static_cast<std::size_t>(y / block) * bw + x / block];
            const float *pa = a.at(x, y), *pb = b.at(x, y);
            for (int c = 0; c < 3; ++c)
                B.deviation[c] += std::abs(0.5 * (static_cast<double>(pa[c]) - pb[c]) - B.h[c] / B.n);
        }
    // The spread of r over each block (its pixels' variance), and the same pooled over
    // the block and its eight neighbours: r's noise is heavy-tailed (a few probed rays
    // a block), and one block's spread alone too uncertain a measure of it.
    // Pooled as squared deviations over degrees of freedom, so that a block of one pixel
    // (an image's corner) adds nothing to its neighbours' measure.
    std::vector<Rgb> squares(blocks.size(), Rgb::Zero());
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        const Block& B = blocks[i];
        squares[i] = (B.r2 - B.r.square() / B.n).max(0.0);
    }
    const double root_two = std::sqrt(2.0), root_two_over_pi = std::sqrt(2.0 / M_PI);
    double sum = 0.0, bias = 0.0, truth = 0.0, shared = 0.0, shared_spread = 0.0;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        const Block& B = blocks[i];
        const int bx = static_cast<int>(i) % bw, by = static_cast<int>(i) / bw;
        Rgb pooled = Rgb::Zero();
        double freedom = 0.0;
        for (int y = std::max(0, by - 1); y <= std::min(bh - 1, by + 1); ++y)
            for (int x = std::max(0, bx - 1); x <= std::min(bw - 1, bx + 1); ++x) {
                const std::size_t j = static_cast<std::size_t>(y) * bw + x;
                pooled += squares[j];
                freedom += blocks[j].n - 1.0;
            }
        if (freedom > 0.0) pooled /= freedom;
        for (int c = 0; c < 3; ++c) {
            // The block's error: the mean of r less its pixels' own noise (their variance
            // over n), with the sign of that mean.
            const double m = B.r[c] / B.n;
            const double beta = std::sqrt(std::max(0.0, m * m - pooled[c] / B.n));
            // The pixels' noise about the block's error: the halves' half-difference less
            // its block mean (what the whole block shares, the field's noise, is in beta),
            // as a mean absolute deviation (robust to a few noisy pixels: a light's edge),
            // over the normal's sqrt(2 / pi) for its deviation.
            const double spread_h = B.n > 1.0 ? B.deviation[c] / B.n * std::sqrt(B.n / (B.n - 1.0)) : 0.0;
            const double sigma = spread_h / root_two_over_pi;
            sum += B.n * (sigma > 0.0 ? spread_h * std::exp(-beta * beta / (2.0 * sigma * sigma)) +
                                            beta * std::erf(beta / (sigma * root_two))
                                      : beta);
            bias += B.n * beta;
            // n times the product of the halves' means, mA mB = (beta + eA) (beta + eB), and
            // its variance from (mA - mB)^2, which estimates var eA + var eB.
            const double ma = B.ra[c] / B.n, mb = B.rb[c] / B.n, d2 = (ma - mb) * (ma - mb);
            shared += B.n * ma * mb;
            shared_spread += B.n * B.n * (std::max(0.0, ma * mb) * d2 + 0.25 * d2 * d2);
            // The truth's sum: the image less the block's error, pixel by pixel.
            const double error = m < 0.0 ? -beta : beta;
            for (int y = by * block; y < std::min(a.height, (by + 1) * block); ++y)
                for (int x = bx * block; x < std::min(a.width, (bx + 1) * block); ++x)
                    truth += std::abs(0.5 * (static_cast<double>(a.at(x, y)[c]) + b.at(x, y)[c]) - error);
        }
    }
    if (truth <= 0.0) return {noise, noise, 0.0, 0.0, 0.0};
    ErrorEstimate out;
    const double values = 3.0 * a.width * a.height;
    // Less twice its standard error: a bias that the noise could make is not counted;
    // one that stands out of it is, and more so as the noise falls.
    out.shared = std::sqrt(std::max(0.0, shared - 2.0 * std::sqrt(shared_spread)) / values) / (truth / values);
    out.noise = noise;
    out.probed = sum / truth;
    out.bias = bias / truth;
    out.total = out.probed;
    return out;
}

CorrectionPlan choose_correction(const CorrectionInputs& in) {
    CorrectionPlan plan;
    const double R = in.scale, P = in.probe, n2 = in.noise * in.noise;
    if (!(R > 0.0) || !(P > 0.0)) return plan;
    const double b2 = in.bias * in.bias, f2 = in.corrected_bias * in.corrected_bias;
    const double c2 = std::max(0.0, in.corrected_noise * in.corrected_noise - n2);
    plan.reading = std::sqrt(b2 + n2 * R / (R + in.more));
    plan.predicted = plan.reading;
    if (!(in.more > 0.0)) return plan;  // no rounds to come: nothing to choose
    for (const double q : {0.125, 0.25, 0.5, 1.0}) {
        if (q < P) continue;
        const double x = in.more / (1.0 + in.probe_cost * (q / P - 1.0));
        const double e = std::sqrt(f2 + n2 * R / (R + x) + c2 * R * (R + x * P / q) / ((R + x) * (R + x)));
        if (plan.q == 0.0 || e < plan.predicted) plan = {q, e, plan.reading};
    }
    if (plan.predicted > plan.reading * (1.0 + in.tolerance)) return {0.0, plan.reading, plan.reading};
    return plan;
}

long chain_steps(long steps, const RoundOptions& rounds) { return half_of(steps, first_scale(rounds)); }

FieldImage field_image(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                       FieldChain& a, FieldChain& b, const FieldImageOptions& o, const RoundOptions& rounds,
                       const sampling::RunOptions& run, const Observer& observe) {
    if (o.steps < 1) throw scenes::OptionError("steps", "must be >= 1, got " + std::to_string(o.steps));
    if (o.record_every < 0)
        throw scenes::OptionError("record_every", "must be >= 0, got " + std::to_string(o.record_every));
    FieldChain* chains[2] = {&a, &b};
    struct Seen {
        solver::RadianceField field;
        long n = 0;
    } seen[2];
    FieldImage out;
    GatherResult gathered;
    std::optional<GBuffer> gbuffer;
    const auto guides = Clock::now();
    if (!o.gather) gbuffer = make_gbuffer(scene, caster, camera, run.threads);
    const auto start = Clock::now();

    solver::RadianceField segment[2];  // each chain's field of the round's steps
    long resume = o.resume_steps;
    out.steps = 2 * resume;
    auto advance = [&](double steps_scale, const sampling::RunOptions& r) {
        const long per_chain = half_of(o.steps, steps_scale);
        if (resume > per_chain)
            throw std::logic_error("field_image: resume_steps " + std::to_string(resume) + " beyond the round's " +
                                   std::to_string(per_chain));
        // Snapshots every `chunk` steps of a chain (and at the round's end), pauses every
        // pause_every; a resumed round begins at its checkpoint.
        const long chunk = o.record_every > 0 ? std::max(1L, o.record_every / 2) : per_chain;
        long done = resume;
        long next_record = std::min(per_chain, (done / chunk + 1) * chunk);
        resume = 0;
        long every = std::max(1L, o.pause_every);
        while (done < per_chain) {
            const long span = next_record - done;  // to the next snapshot or the round's end
            long count = span;
            if (o.pause) {
                count = std::min(count, every);
                // Following the clock, a short rest joins this interval: each pause costs
                // the chains' difference in speed over the interval before it.
                if (o.pause_seconds > 0.0 && span - count < every / 2) count = span;
            }
            const auto t_interval = Clock::now();
            // Each chain's steps so far in this call, and the progress of both as one.
            long chain_done[2] = {0, 0};
            std::mutex progress_lock;
            auto progress_of = [&](int h) {
                sampling::ProgressCallback progress;
                if (r.progress)
                    progress = [&, h](const sampling::Progress& p) {
                        const std::lock_guard<std::mutex> lock(progress_lock);
                        chain_done[h] = p.done;
                        sampling::Progress q = p;
                        q.phase = "solve";
                        q.done = 2 * done + chain_done[0] + chain_done[1];
                        q.total = 2 * per_chain;
                        r.progress(q);
                    };
                return progress;
            };
            auto advance_chain = [&](int h) { chains[h]->advance(count, progress_of(h)); };
            long ran = count;           // steps of each chain in this interval
            bool freely = false;        // to the span's end, go_on asked at each step
            if (o.chains_side_by_side) {
                // Both chains' steps on all the threads (solver/pipeline.h): a thread
                // that has none of one chain's left helps with the other's, and the
                // pause waits for a step, not for the slower chain. Else each chain on
                // its share of the threads.
                const long length = o.go_on ? span : count;
                std::vector<solver::StepStream> both;
                for (int h = 0; h < 2; ++h)
                    if (auto s = chains[h]->stream(length, progress_of(h))) both.push_back(std::move(*s));
                if (both.size() == 2) {
                    freely = static_cast<bool>(o.go_on);
                    count = length;
                    const auto go_on = [&o](long) { return o.go_on(); };
                    ran = solver::run_step_streams(both, r.threads, o.go_on ? go_on : std::function<bool(long)>());
                } else {
                    run_threads(2, advance_chain);
                }
            } else {
                for (int h = 0; h < 2; ++h) advance_chain(h);
            }
            done += ran;
            out.steps += 2 * ran;
            if (o.pause_seconds > 0.0 && !freely) {
                const double took = since(t_interval);
                // Quick steps: at once to about half of pause_seconds (at least twice the
                // steps, at most 64 times), not one doubling per pause.
                if (count == every && took < 0.5 * o.pause_seconds)
                    every = static_cast<long>(std::min(
                        std::clamp(0.5 * o.pause_seconds / std::max(took, 1e-9), 2.0, 64.0) * static_cast<double>(every),
                        2.0 * static_cast<double>(per_chain)));  // no further than the round's steps
                else if (took > o.pause_seconds)
                    every = std::max(std::max(1L, o.pause_every), every / 2);
            }
            if (done == next_record) {
                next_record = std::min(per_chain, next_record + chunk);
                if (observe && o.record_every > 0 && a.averaged() > 0 && b.averaged() > 0) {
                    const auto [field, estimate] =
                        combine(scene, a.field(r.threads), a.averaged(), b.field(r.threads), b.averaged(), r.threads);
                    Snapshot s;
                    s.steps = out.steps;
                    s.seconds = since(start);
                    s.field = &field;
                    s.field_estimate = estimate;
                    observe(s);
                }
            }
            if ((o.pause && !o.pause(done)) || ran < count) {
                if (done == per_chain) return Advanced::last;
                return a.averaged() > seen[0].n && b.averaged() > seen[1].n ? Advanced::cut : Advanced::nothing_new;
            }
        }
        return Advanced::all;
    };
    // The correction "auto": on where it has a probe to decide from and no fixed q.
    const AutoCorrection automatic{o.gather && o.auto_correction && o.gather_options.correction == 0.0 &&
                                       o.gather_options.bias_probe > 0.0,
                                   o.gather_options.bias_probe};
    auto pass_options = [&](double scale, std::uint64_t pass, double correction) {
        GatherOptions g = o.gather_options;
        if (automatic.on) {
            g.correction = correction;
            g.corrected_image = true;
        }
        g.gather_rays = static_cast<int>(half_of(g.gather_rays, scale));
        // A pixel of one sample is its centre (spp = 1): passes of a pixel's area keep two.
        g.spp = static_cast<int>(half_of(g.spp, scale, g.spp > 1 ? 2 : 1));
        if (g.emission_samples > 0) g.emission_samples = static_cast<int>(half_of(g.emission_samples, scale));
        g.pass = pass;
        return g;
    };
    double correction = o.gather_options.correction;  // of the latest pass, for the field's probe
    auto render = [&](int h, double scale, std::uint64_t pass, double q, const sampling::RunOptions& r) {
        FieldChain& chain = *chains[h];
        solver::RadianceField now = chain.field(r.threads);
        const long n = chain.averaged();
        if (n <= seen[h].n)
            throw std::logic_error("field_image: chain " + std::to_string(h) + " averaged no new steps (" +
                                   std::to_string(n) + "): give it SolverOptions::steps = chain_steps()");
        segment[h] = between(seen[h].field, seen[h].n, now, n, r.threads);
        seen[h] = {std::move(now), n};
        if (!o.gather) return Pass{shade(scene, segment[h], *gbuffer, o.shading, r.threads)};
        const GatherOptions g = pass_options(scale, pass, q);
        correction = g.correction;
        GatherResult result = final_gather(scene, caster, segment[h], camera, g, r);
        add_gather(gathered, result, scale, r.threads);
        // Without the probe the bias image lacks the field's error: the halves' rule alone.
        Pass made{std::move(result.image), result.bias_probed ? std::move(result.bias) : Image()};
        if (automatic.on && !result.corrected.rgb.empty()) {
            made.corrected = std::move(result.corrected);
            made.corrected_bias = std::move(result.corrected_bias);
            const double rays = static_cast<double>(result.camera_rays + result.shadow_rays + result.gather_rays +
                                                    result.bias_rays);
            made.probe_share = rays > 0.0 ? result.bias_rays / rays : 0.0;
        }
        return made;
    };
    // Half A's pass again, its samples, chain B's field (see Shape); none for the patch image.
    auto probe = [&](double scale, std::uint64_t pass, const sampling::RunOptions& r) {
        if (!o.gather) return Image();
        GatherOptions g = pass_options(scale, pass, correction);
        g.bias_probe = 0.0;  // its image is all that is used
        return final_gather(scene, caster, segment[1], camera, g, r).image;
    };
    auto after = [&](long round, const Image& image, double estimate, double seconds) {
        out.image = image;
        // The chains' fields as this round's passes read them (run_rounds renders both
        // halves before it calls after()): each chain's field is made once a round, on
        // ranks an exchange each, not again here.
        for (int h = 0; h < 2; ++h)
            if (seen[h].n != chains[h]->averaged())
                throw std::logic_error("field_image: chain " + std::to_string(h) + " moved on after its pass");
        std::tie(out.field, out.field_estimate) =
            combine(scene, seen[0].field, seen[0].n, seen[1].field, seen[1].n, run.threads);
        if (!observe) return;
        Snapshot s;
        s.steps = out.steps;
        s.seconds = seconds;
        s.field = &out.field;
        s.field_estimate = out.field_estimate;
        s.image = &out.image;
        s.image_estimate = estimate;
        s.round = round;
        observe(s);
    };
    out.rounds = run_rounds(rounds, run, advance, render, probe, after, automatic);
    out.rounds.seconds_render += std::chrono::duration<double>(start - guides).count();  // the patch image's G-buffer
    if (o.gather) {
        // Both halves of every pass were added with their round's scale.
        const double w = 1.0 / (2.0 * out.rounds.scale);
        gathered.image = out.image;
        gathered.direct = scaled(gathered.direct, w, run.threads);
        gathered.indirect = scaled(gathered.indirect, w, run.threads);
        gathered.indirect_filtered = scaled(gathered.indirect_filtered, w, run.threads);
        gathered.bias = scaled(gathered.bias, w, run.threads);
        out.gather = std::move(gathered);
    }
    return out;
}

TracedImage traced_image(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                         const PathTraceOptions& o, const RoundOptions& rounds, const sampling::RunOptions& run,
                         const Observer& observe) {
    if (o.spp < 1) throw scenes::OptionError("spp", "must be >= 1, got " + std::to_string(o.spp));
    TracedImage out;
    auto advance = [](double, const sampling::RunOptions&) { return Advanced::all; };
    auto render = [&](int, double scale, std::uint64_t pass, double, const sampling::RunOptions& r) {
        PathTraceOptions p = o;
        p.spp = static_cast<int>(half_of(o.spp, scale));
        p.pass = pass;
        PathTraceResult traced = path_trace(scene, caster, camera, p, r);
        out.traced.paths += traced.paths;
        out.traced.rays += traced.rays;
        out.traced.seconds += traced.seconds;
        return Pass{std::move(traced.image)};
    };
    auto after = [&](long round, const Image& image, double estimate, double seconds) {
        out.traced.image = image;
        if (!observe) return;
        Snapshot s;
        s.seconds = seconds;
        s.image = &out.traced.image;
        s.image_estimate = estimate;
        s.round = round;
        observe(s);
    };
    auto probe = [](double, std::uint64_t, const sampling::RunOptions&) { return Image(); };  // no field
    out.rounds = run_rounds(rounds, run, advance, render, probe, after);
    return out;
}

}  // namespace raybundle::render
