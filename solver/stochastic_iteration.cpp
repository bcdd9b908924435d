#include "solver/stochastic_iteration.h"

#include "sampling/directions.h"
#include "sampling/streams.h"
#include "scenes/errors.h"
#include "scenes/brdf.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace raybundle::solver {

using scenes::Rgb;
using scenes::Vec3;
using Clock = std::chrono::steady_clock;

StochasticIteration::StochasticIteration(const Transport& transport, visibility::BackendSet& backends,
                                         const SolverOptions& options, const sampling::RunOptions& run)
    : Solver(options.steps),
      transport_(transport),
      backends_(backends),
      options_(decided(options, transport_)),
      run_(run),
      glossy_(transport.glossy()),
      directions_(run.seed, run.chain),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)) {
    init(options);
}

StochasticIteration::StochasticIteration(const Transport& transport, std::unique_ptr<visibility::BackendSet> backends,
                                         const SolverOptions& options, const sampling::RunOptions& run)
    : Solver(options.steps),
      transport_(transport),
      own_set_(std::move(backends)),
      backends_(*own_set_),
      options_(decided(options, transport_)),
      run_(run),
      glossy_(transport.glossy()),
      directions_(run.seed, run.chain),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)) {
    init(options);
}

StochasticIteration::StochasticIteration(const Transport& transport, visibility::Backend& backend,
                                         const SolverOptions& options, const sampling::RunOptions& run)
    : StochasticIteration(transport, std::make_unique<visibility::BackendSet>(backend), options, run) {}

StochasticIteration::StochasticIteration(const scenes::Scene& scene, visibility::Backend& backend,
                                         const SolverOptions& options, const sampling::RunOptions& run)
    : Solver(options.steps),
      own_(std::make_unique<Transport>(scene)),
      transport_(*own_),
      own_set_(std::make_unique<visibility::BackendSet>(backend)),
      backends_(*own_set_),
      options_(decided(options, transport_)),
      run_(run),
      glossy_(scene.has_glossy()),
      directions_(run.seed, run.chain),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)) {
    init(options);
}

void StochasticIteration::init(const SolverOptions& options) {
    const std::size_t n = transport_.patches();
    irradiance_.assign(n + 2, Rgb::Zero());
    next_.assign(n + 2, Rgb::Zero());
    outgoing_.assign(n + 2, Rgb::Zero());
    sum_.assign(n, Rgb::Zero());
    report_.method = "iteration";
    report_.visibility = describe(backends_);
    report_.bytes_per_patch = 4 * sizeof(Rgb);
    report_.details = {{"both_ways", options_.both_ways}};
    if (glossy_) {
        to_eye_ = transport_.directions_to_eye();
        report_.decisions["shading"] = "every step, towards the eye (the scene has glossy materials)";
    } else {
        report_.decisions["shading"] = "once at the end (purely diffuse scene)";
    }
    // Burn-in: the chain starts from no reflected light, and the k-th iterate still
    // lacks the light of bounces beyond k, which decays like rho^k for the largest
    // reflectance rho. Averaging from the start would carry that deficit, summed over
    // the first steps, divided by the step count: a bias falling like 1/steps. The
    // first B steps, with rho^B <= 1e-4, are left out of the average; at most a tenth
    // of the steps. (On the Cornell box the bias is below the noise: the image mean
    // varies by +-1.5 % between seeds at 4,000 steps either way.)
    const double rho = std::min(transport_.max_reflectance(), 0.9999);
    const long wanted = rho > 0.0 ? static_cast<long>(std::ceil(std::log(1e-4) / std::log(rho))) : 0;
    burn_in_ = std::min(wanted, options_.steps / 10);
    report_.details["burn_in_steps"] = burn_in_;
    report_.decisions["burn_in"] = std::to_string(burn_in_) + " steps left out of the average (largest reflectance " +
                                   std::to_string(rho) + ": its start-up deficit below 1e-4 after " +
                                   std::to_string(wanted) + " steps; at most a tenth of the steps)";
    if (*options_.frame && glossy_)
        throw scenes::OptionError("frame", "needs a purely diffuse scene (glossy patches reflect the light of one "
                                           "direction per step)");
    // High albedo (solver.h, kStableAlbedo): what was decided, and why.
    const std::string why = rho > kStableAlbedo
                                ? "the largest reflectance (albedo plus specular), " + std::to_string(rho) +
                                      ", passes sqrt(3)/2: with one direction per step the chain's variance grows "
                                      "without bound (docs/stability.md)"
                                : "the largest reflectance (albedo plus specular), " + std::to_string(rho) + ", is below sqrt(3)/2";
    report_.details["frame"] = *options_.frame;
    report_.details["ambient"] = *options_.ambient;
    if (*options_.ambient) {
        const Rgb ambient = transport_.mean_emitted() / (Rgb::Ones() - transport_.mean_albedo());
        window_sum_.assign(n, Rgb::Zero());
        c_.assign(n, ambient);
        // g_i = 1 before the first step, then at once what the patch sees: a pseudo-step
        // of a fully lit patch, of weight 1e-6 (a real step's is ~1/4).
        covered_sum_.assign(n, 1e-6);
        exposed_sum_.assign(n, 1e-6);
        lit_.assign(n + 2, 0.0);
        seen_.assign(n + 2, 0.0);
        voids_ = options_.map.sky;
        for (std::size_t i = 0; i < n; ++i)
            if (!transport_.is_glossy(i)) irradiance_[i] = ambient / 4.0;
        report_.details["ambient_start"] = {ambient[0], ambient[1], ambient[2]};
        report_.decisions["ambient"] =
            "on: each diffuse patch's incoming light is estimated relative to its own recent mean (a control "
            "variate: what a direction brings less that mean, plus the mean over what the direction covers), "
            "which keeps a high-albedo scene's noise bounded; the chain starts from the ambient radiance (mean "
            "emission / (1 - mean albedo)); the estimator: sum_j A_ij (L_j - c_i) + c_i T_i f_i + c_i (1/4 - T_i) "
            "g_i (docs/stability.md); " +
            (options.ambient ? std::string("--ambient given") : why);
    } else {
        report_.decisions["ambient"] = "off: the estimator of 004 section 4.4.1 as it is, from no reflected light; " +
                                       (options.ambient ? std::string("--no-ambient given") : why);
    }
    const std::string per_direction = options_.both_ways ? "w and -w from one geometry matrix (weight 1/2 each)" : "w only";
    report_.decisions["directions_per_step"] =
        *options_.frame ? "the three axes of a random orthogonal frame (weight 1/3 each), each " + per_direction + "; " +
                              (options.frame ? std::string("--frame given") : why)
                        : "one, " + per_direction;
}

void StochasticIteration::close_window(bool take_mean) {
    if (take_mean)
        for (std::size_t i = 0; i < c_.size(); ++i) c_[i] = (4.0 / static_cast<double>(window_steps_)) * window_sum_[i];
    std::fill(window_sum_.begin(), window_sum_.end(), Rgb::Zero());
    window_steps_ = 0;
}

void StochasticIteration::step(const Vec3* ws, const visibility::GeometryMatrix* matrices, int count) {
    const Transport& t = transport_;
    const std::size_t n = t.patches();
    const bool both = options_.both_ways;
    // With both directions, every entry also carries light along -w. Each patch faces
    // exactly one of +-w, so it receives once; weight 1/2 keeps the expectation: the
    // pair (w, -w) is sampled with twice the density of w alone. A frame's three
    // directions weigh a third each.
    const double weight = (both ? 0.5 : 1.0) / count;
    std::fill(next_.begin(), next_.end(), Rgb::Zero());
    if (*options_.ambient) {
        std::fill(lit_.begin(), lit_.end(), 0.0);
        std::fill(seen_.begin(), seen_.end(), 0.0);
    }
    for (int d = 0; d < count; ++d) {
        const Vec3& w = ws[d];
        // Radiance every patch sends along w (with both directions: along whichever of
        // +-w it faces): emission plus the reflection of the irradiance of the previous
        // step, which arrived along w_prev (or whichever of +-w_prev the patch faced).
        for (std::size_t j = 0; j < n; ++j) {
            if (t.is_glossy(j)) {
                const Vec3 out = t.departure(j, w, both);
                outgoing_[j] = t.emitted(j, out);
                if (steps_ > 0) outgoing_[j] += t.reflected(j, t.arrival(j, previous_, both), out, irradiance_[j]);
            } else {
                outgoing_[j] = t.emitted(j, w) + t.diffuse_reflectance(j) * irradiance_[j];
            }
        }
        t.set_sky(w, outgoing_);
        t.gather(matrices[d], outgoing_, next_, both, weight);
        if (*options_.ambient) t.exposure(matrices[d], lit_, seen_, both, weight);
    }
    const Vec3& w = ws[count - 1];
    if (*options_.ambient) {
        // c_i and g_i from the start and the steps before this one; f_i this step's.
        if (steps_ == burn_in_ && burn_in_ > 0) {
            // The first averaged step: c_i from the burn-in's last steps (those of the
            // window under way, when there are enough), then windows anew, so that
            // the start does not linger in c_i (a dark room started bright).
            close_window(window_steps_ >= 8);
            window_size_ = 16;
        }
        for (std::size_t i = 0; i < n; ++i) {
            if (t.is_glossy(i)) continue;
            double T = 0.0;
            for (int d = 0; d < count; ++d) T += t.receiving_share(i, ws[d], both) / count;
            const double g = covered_sum_[i] / exposed_sum_[i];
            const double f = voids_ ? (seen_[i] > 0.0 ? lit_[i] / seen_[i] : g) : (T > 0.0 ? lit_[i] / T : g);
            // The departure's entries scaled from the pixels' exposure to the exact one
            // (T f / lit = T / seen): one pixel on a patch seen edge-on weighs its area
            // against the patch's, which high albedo would feed back (a 1 with an exact
            // backend).
            const double scale = lit_[i] > 0.0 ? T * f / lit_[i] : 0.0;
            next_[i] = scale * (next_[i] - lit_[i] * c_[i]) + (T * f + (0.25 - T) * g) * c_[i];
            covered_sum_[i] += T * f;
            exposed_sum_[i] += T;
        }
        // c_i from the window just completed: windows of 16, 32, 64, ... steps, so that
        // c_i is a mean over many steps (a mean over few feeds its noise back) and over
        // recent ones (the start, say the ambient radiance in a dark room, is forgotten).
        for (std::size_t i = 0; i < n; ++i) window_sum_[i] += next_[i];
        if (++window_steps_ == window_size_) {
            close_window(true);
            window_size_ *= 2;
        }
    }
    irradiance_.swap(next_);
    previous_ = w;
    ++steps_;
    if (steps_ <= burn_in_) return;  // still forgetting the start (init())
    if (glossy_) {
        for (std::size_t i = 0; i < n; ++i) {
            if ((irradiance_[i] == 0.0).all()) continue;
            sum_[i] += t.reflected(i, t.arrival(i, w, both), to_eye_[i], irradiance_[i]);
        }
    } else {
        for (std::size_t i = 0; i < n; ++i) sum_[i] += irradiance_[i];
    }

}

std::optional<StepStream> StochasticIteration::stream(long total, bool shared) {
    if (backends_.threads() == 1 && backends_.batch_directions() > 1) return std::nullopt;  // advance()'s batches
    const int per_step = *options_.frame ? 3 : 1;
    StepStream s;
    s.count = std::max(0L, total);
    // Steps under way: enough that the threads never wait for the light to move (one
    // step's move is shorter than its matrices), few enough that the matrices kept
    // (the slots', reused from step to step) stay a small multiple of the threads'
    // (also another chain's threads, beside which it runs); one step alone on one thread.
    const int threads = backends_.threads();
    s.window = threads > 1 || shared ? 2L * threads + 2 : 1;
    if (slots_.size() < static_cast<std::size_t>(s.window)) slots_.resize(static_cast<std::size_t>(s.window));
    for (int t = 0; t < threads; ++t) s.backends.push_back(&backends_.at(t));
    // The directions and jitters are drawn in step order, as one thread alone draws them.
    s.begin = [this, per_step](long, long slot) {
        Slot& at = slots_[static_cast<std::size_t>(slot)];
        if (*options_.frame) {
            const auto frame = directions_.next_frame();
            std::copy(frame.begin(), frame.end(), at.w.begin());
        } else {
            at.w[0] = directions_.next();
        }
        for (int d = 0; d < per_step; ++d) {
            const double y = jitter_.uniform(), x = jitter_.uniform();  // y first: see sampling/rng.h
            at.jitter[static_cast<std::size_t>(d)] = {x, y};
        }
    };
    s.compute = [this, per_step](long slot, visibility::Backend& backend) {
        Slot& at = slots_[static_cast<std::size_t>(slot)];
        const auto t0 = Clock::now();
        for (std::size_t d = 0; d < static_cast<std::size_t>(per_step); ++d)
            backend.transfer(at.w[d], at.jitter[d], at.matrices[d]);
        at.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    };
    const auto start = Clock::now();
    s.finish = [this, per_step, total, start](long item, long slot) {
        Slot& at = slots_[static_cast<std::size_t>(slot)];
        const auto t1 = Clock::now();
        step(at.w.data(), at.matrices.data(), per_step);
        for (int d = 0; d < per_step; ++d) report_.entries_total += at.matrices[static_cast<std::size_t>(d)].entries.size();
        report_.directions += per_step;
        ++report_.steps;
        report_.seconds_visibility += at.seconds;
        report_.seconds_transport += std::chrono::duration<double>(Clock::now() - t1).count();
        run_.report("solve", item + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
    };
    return s;
}

void StochasticIteration::advance(long total) {
    if (total <= 0) return;
    // Backends side by side (or one that takes one direction at a time): the steps as a
    // stream (solver/pipeline.h). Each thread takes the next direction as it finishes
    // one, and whichever finds the next step's matrices done moves the light along them.
    if (auto one = stream(total, false)) return run_step_stream(std::move(*one));
    // One backend that takes batches (BackendSet::batch_directions: what one submission
    // of a GPU takes): the light moves along one batch's matrices while the backend
    // computes the next batch's. The directions and jitters are drawn in the same order
    // as above, however the steps are split into calls.
    const int per_step = *options_.frame ? 3 : 1;
    const long batch = std::max(1L, static_cast<long>(backends_.batch_directions() / per_step));
    std::vector<Vec3> ws, next_ws;
    std::vector<Eigen::Vector2d> offsets, next_offsets;
    const auto start = Clock::now();
    const auto draw = [&](long count, std::vector<Vec3>& w, std::vector<Eigen::Vector2d>& o) {
        w.clear();
        o.clear();
        for (long b = 0; b < count; ++b) {
            if (*options_.frame) {
                for (const Vec3& axis : directions_.next_frame()) w.push_back(axis);
            } else {
                w.push_back(directions_.next());
            }
            for (int d = 0; d < per_step; ++d) {
                const double y = jitter_.uniform(), x = jitter_.uniform();  // y first: see sampling/rng.h
                o.emplace_back(x, y);
            }
        }
    };
    double moved = 0.0;  // seconds of moving the light inside the last transfer_batch
    long m = 0;          // steps done in this call
    const auto move_light = [&](long count) {
        const auto t1 = Clock::now();
        for (long b = 0; b < count; ++b, ++m) {
            step(&ws[b * per_step], &matrices_[b * per_step], per_step);
            for (int d = 0; d < per_step; ++d) report_.entries_total += matrices_[b * per_step + d].entries.size();
            report_.directions += per_step;
            ++report_.steps;
            run_.report("solve", m + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
        }
        moved = std::chrono::duration<double>(Clock::now() - t1).count();
        report_.seconds_transport += moved;
    };
    long count = std::min(batch, total);
    draw(count, ws, offsets);
    auto t0 = Clock::now();
    backends_.transfer_batch(ws, offsets, matrices_);
    report_.seconds_visibility += std::chrono::duration<double>(Clock::now() - t0).count();
    for (long drawn = count;;) {
        if (drawn == total) {
            move_light(count);
            break;
        }
        // The next batch's matrices beside this batch's steps.
        const long next = std::min(batch, total - drawn);
        draw(next, next_ws, next_offsets);
        t0 = Clock::now();
        moved = 0.0;
        backends_.transfer_batch(next_ws, next_offsets, next_matrices_, [&] { move_light(count); });
        report_.seconds_visibility += std::chrono::duration<double>(Clock::now() - t0).count() - moved;
        ws.swap(next_ws);
        offsets.swap(next_offsets);
        matrices_.swap(next_matrices_);
        count = next;
        drawn += next;
    }
}

void StochasticIteration::save(StateWriter& out) const {
    out.tag("iteration");
    out.put(steps_);
    out.put(irradiance_);
    out.put(sum_);
    out.put(previous_);
    out.put(directions_.generator());
    out.put(jitter_);
    out.put(*options_.ambient);
    out.put(*options_.frame);
    if (*options_.ambient) {
        out.put(c_);
        out.put(window_sum_);
        out.put(window_steps_);
        out.put(window_size_);
        out.put(covered_sum_);
        out.put(exposed_sum_);
    }
    save_counters(out, report_);
}

void StochasticIteration::restore(StateReader& in) {
    in.expect("iteration");
    in.get(steps_);
    in.get(irradiance_);
    in.get(sum_);
    in.get(previous_);
    in.get(directions_.generator());
    in.get(jitter_);
    if (in.flag() != *options_.ambient)
        throw StateError("saved with the ambient variate " + std::string(*options_.ambient ? "off" : "on"));
    if (in.flag() != *options_.frame) throw StateError("saved with frames " + std::string(*options_.frame ? "off" : "on"));
    if (*options_.ambient) {
        in.get(c_);
        in.get(window_sum_);
        in.get(window_steps_);
        in.get(window_size_);
        in.get(covered_sum_);
        in.get(exposed_sum_);
    }
    restore_counters(in, report_);
}

RadianceField StochasticIteration::field(int threads) const {
    return transport_.field_from(sum_, averaged(), to_eye_, threads > 0 ? threads : run_.threads);
}

}  // namespace raybundle::solver
