#include "solver/global_walks.h"

#include "sampling/streams.h"
#include "sampling/walk_sampler.h"
#include "scenes/errors.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace raybundle::solver {

using Clock = std::chrono::steady_clock;

const char* walk_method_name(WalkMethod m) {
    switch (m) {
        case WalkMethod::walk: return "walk";
        case WalkMethod::combined: return "combined";
        case WalkMethod::bidirectional: return "bidirectional";
    }
    return "?";
}

namespace {

double binomial(int n, int k) {
    double r = 1.0;
    for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
    return r;
}

// Index of the table entry (bounce b, last direction t), b <= t.
std::size_t table_index(int b, int t) { return static_cast<std::size_t>(t) * (t + 1) / 2 + b; }

}  // namespace

double GlobalWalks::truncation_factor(double albedo, int depth, bool unbiased) {
    return unbiased ? 1.0 : 1.0 - std::pow(albedo, depth + 1);
}

GlobalWalks::GlobalWalks(const Transport& transport, visibility::Backend& backend, WalkMethod method,
                         const SolverOptions& options, const sampling::RunOptions& run)
    : GlobalWalks(transport, std::make_unique<visibility::BackendSet>(backend), nullptr, method, options, run) {}

GlobalWalks::GlobalWalks(const Transport& transport, visibility::BackendSet& backends, WalkMethod method,
                         const SolverOptions& options, const sampling::RunOptions& run)
    : GlobalWalks(transport, nullptr, &backends, method, options, run) {}

GlobalWalks::GlobalWalks(const Transport& transport, std::unique_ptr<visibility::BackendSet> backends,
                         WalkMethod method, const SolverOptions& options, const sampling::RunOptions& run)
    : GlobalWalks(transport, std::move(backends), nullptr, method, options, run) {}

namespace {

// The options a walk method must have, checked before the sampler sees them.
const SolverOptions& checked(const SolverOptions& o) {
    if (o.steps < 1) throw scenes::OptionError("steps", "walks must be >= 1, got " + std::to_string(o.steps));
    const int limit = o.sampler == sampling::SamplerKind::sobol    ? sampling::WalkSampler::kMaxSobolDepth
                      : o.sampler == sampling::SamplerKind::halton ? sampling::WalkSampler::kMaxHaltonDepth
                                                                    : 32;
    if (o.depth < 1 || o.depth > limit)
        throw scenes::OptionError("depth", "must be in 1.." + std::to_string(limit) + " with the " +
                                               sampling::sampler_name(o.sampler) + " sampler, got " +
                                               std::to_string(o.depth));
    if (sampling::adaptive(o.sampler)) {
        if (!(o.mutation_size > 0.0 && o.mutation_size <= 1.0))
            throw scenes::OptionError("mutation_size", "must be in (0, 1], got " + std::to_string(o.mutation_size));
        if (!(o.large_step >= 0.0 && o.large_step <= 1.0))
            throw scenes::OptionError("large_step", "must be in [0, 1], got " + std::to_string(o.large_step));
        if (o.seed_walks < 0)
            throw scenes::OptionError("seed_walks", "must be >= 0 (0: automatic), got " + std::to_string(o.seed_walks));
    }
    if (o.unbiased && o.sampler != sampling::SamplerKind::random)
        throw scenes::OptionError("unbiased", std::string("needs the random sampler: the correction carries one walk's "
                                                          "light into the next, and consecutive ") +
                                                  sampling::sampler_name(o.sampler) + " points are correlated");
    return o;
}

}  // namespace

GlobalWalks::GlobalWalks(const Transport& transport, std::unique_ptr<visibility::BackendSet> own,
                         visibility::BackendSet* backends, WalkMethod method, const SolverOptions& options,
                         const sampling::RunOptions& run)
    : Solver(options.steps),
      t_(transport),
      own_set_(std::move(own)),
      backends_(own_set_ ? *own_set_ : *backends),
      method_(method),
      options_(checked(options)),
      run_(run),
      glossy_(transport.glossy()),
      source_(make_walk_source(options_, run, transport.patches())),
      point_(static_cast<std::size_t>(2 * options.depth), 0.0),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)) {
    const std::size_t n = t_.patches(), slots = t_.slots();
    const int D = options.depth;
    work_.resize(1);
    Work& work = work_.front();
    work.dirs.resize(static_cast<std::size_t>(D));
    work.out.assign(slots, Rgb::Zero());
    sum_.assign(n, Rgb::Zero());
    work.walk.assign(n, Rgb::Zero());
    std::size_t vectors = 3;  // work.out, sum_ and work.walk
    if (method == WalkMethod::walk) {
        work.irr.assign(slots, Rgb::Zero());
        work.next.assign(slots, Rgb::Zero());
        vectors += 2;
        if (options.unbiased) {
            work.chain.assign(slots, Rgb::Zero());
            ++vectors;
        }
        report_.decisions["storage"] = "plain walk: the max-bounce irradiance" +
                                       std::string(options.unbiased ? " and the last-bounce chain (unbiased)" : "");
    } else {
        const std::size_t entries = glossy_ ? table_index(0, D) : static_cast<std::size_t>(D);
        work.table.assign(entries, std::vector<Rgb>(slots, Rgb::Zero()));
        vectors += entries;
        report_.decisions["storage"] = glossy_ ? "the bounce table, D(D+1)/2 = " + std::to_string(entries) +
                                                     " entries (glossy materials need the direction each arrived along)"
                                               : "one running sum per bounce, D = " + std::to_string(D) +
                                                     " (diffuse: the D(D+1)/2 table collapses)";
    }
    if (options.unbiased) {
        correction_.assign(n, Rgb::Zero());
        ++vectors;
    }
    report_.method = walk_method_name(method);
    report_.visibility = describe(backends_);
    // Walks of a source that does not adapt are independent of each other (without the
    // unbiased correction, which carries one walk's light into the next): whole walks go
    // side by side (stream()), each walk under way with vectors of its own
    // (walks_under_way). Otherwise a walk's D directions do (at most D threads busy).
    // One backend that takes batches (a GPU's) gets a walk's directions in one.
    const bool batches = backends_.threads() == 1 && backends_.batch_directions() > 1;
    whole_walks_ = !source_->adapts() && !options.unbiased && !batches;
    walk_vectors_ = vectors - 1;  // sum_ is the chain's, the others each walk's
    const int under_way = walks_under_way(backends_.threads());
    report_.decisions["walk_threads"] =
        batches ? std::string("one walk at a time, its directions in one batch of the backend's")
        : !whole_walks_ ? (backends_.threads() == 1
                               ? std::string("one walk at a time")
                               : std::string("one walk at a time, its directions side by side (") +
                                     (options.unbiased ? "the unbiased correction links the walks" : "the source adapts") + ")")
        : backends_.threads() == 1 ? std::string("one walk at a time (two under way beside another chain's)")
                                   : "whole walks side by side on " + std::to_string(backends_.threads()) +
                                         " threads, up to " + std::to_string(under_way) + " under way";
    grow_work(whole_walks_ && backends_.threads() > 1 ? static_cast<std::size_t>(under_way) : 1);
    report_.details = {{"depth", D}, {"sampler", sampling::sampler_name(options.sampler)}, {"unbiased", options.unbiased}};
    if (glossy_) {
        to_eye_ = t_.directions_to_eye();
        report_.decisions["shading"] = "every walk, towards the eye (the scene has glossy materials)";
    } else {
        report_.decisions["shading"] = "once at the end (purely diffuse scene)";
    }
    if (source_->adapts()) {
        weights_ = importance_weights(t_, glossy_);
        report_.decisions["importance"] =
            "the image's luminance of a walk, from " + std::to_string(weights_.rays) + " camera rays (" +
            std::to_string(static_cast<int>(std::lround(100.0 * weights_.covered))) + " % meet a patch's front)";
    }
}

SolverReport GlobalWalks::report() const {
    SolverReport r = report_;
    source_->report(r);
    if (source_->adapts()) r.details["image_coverage"] = weights_.covered;
    return r;
}

void GlobalWalks::draw_jitters(Work& work) {
    work.jitters.clear();
    for (std::size_t d = 0; d < work.dirs.size(); ++d) {
        const double y = jitter_.uniform(), x = jitter_.uniform();  // y first: see sampling/rng.h
        work.jitters.emplace_back(x, y);
    }
}

void GlobalWalks::transfer_all(Work& work, visibility::Backend* alone) {
    const auto t0 = Clock::now();
    if (alone) {
        work.matrices.resize(work.dirs.size());
        for (std::size_t d = 0; d < work.dirs.size(); ++d) alone->transfer(work.dirs[d], work.jitters[d], work.matrices[d]);
    } else {
        backends_.transfer_batch(work.dirs, work.jitters, work.matrices);
    }
    work.seconds_visibility += std::chrono::duration<double>(Clock::now() - t0).count();
    for (const auto& m : work.matrices) work.entries += m.entries.size();
    work.directions += static_cast<long>(work.matrices.size());
}

void GlobalWalks::count(Work& work) {
    report_.seconds_visibility += work.seconds_visibility;
    report_.seconds_transport += work.seconds_transport;
    report_.entries_total += work.entries;
    report_.directions += work.directions;
    work.seconds_visibility = work.seconds_transport = 0.0;
    work.entries = 0;
    work.directions = 0;
}

Rgb GlobalWalks::walk_emission(std::size_t j, const Vec3& out) const {
    Rgb e = t_.emitted(j, out);
    if (correction_scale_ > 0.0)
        e += correction_scale_ * t_.reflected(j, t_.arrival(j, correction_dir_, correction_both_), out, correction_[j]);
    return e;
}

void GlobalWalks::accumulate(Work& work, std::size_t i, const Vec3& arrived, const Rgb& irradiance) const {
    if (glossy_)
        work.walk[i] += t_.reflected(i, arrived, to_eye_[i], irradiance);
    else
        work.walk[i] += irradiance;
}

void GlobalWalks::walk_plain(Work& work) {
    const std::size_t n = t_.patches();
    const int D = options_.depth;
    const bool unbiased = options_.unbiased;
    std::fill(work.irr.begin(), work.irr.end(), Rgb::Zero());
    if (unbiased) std::fill(work.chain.begin(), work.chain.end(), Rgb::Zero());
    Vec3 prev = Vec3::Zero();
    for (int d = 0; d < D; ++d) {
        const Vec3& w = work.dirs[d];
        const auto& matrix = work.matrices[d];
        const auto t0 = Clock::now();
        // I <- A(w) (Le + C + 4 pi F I)
        for (std::size_t j = 0; j < n; ++j) {
            work.out[j] = walk_emission(j, w);
            if (d > 0) work.out[j] += t_.reflected(j, prev, w, work.irr[j]);
        }
        t_.set_sky(w, work.out);
        std::fill(work.next.begin(), work.next.end(), Rgb::Zero());
        t_.gather(matrix, work.out, work.next, false, 1.0);
        work.irr.swap(work.next);
        if (unbiased) {
            // J <- A(w) 4 pi F J, started from the emission (and sky): exactly d bounces.
            for (std::size_t j = 0; j < n; ++j)
                work.out[j] = d == 0 ? walk_emission(j, w) : t_.reflected(j, prev, w, work.chain[j]);
            if (d == 0)
                t_.set_sky(w, work.out);
            else
                work.out[t_.sky_front()] = work.out[t_.sky_back()] = Rgb::Zero();
            std::fill(work.next.begin(), work.next.end(), Rgb::Zero());
            t_.gather(matrix, work.out, work.next, false, 1.0);
            work.chain.swap(work.next);
        }
        prev = w;
        work.seconds_transport += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    for (std::size_t i = 0; i < n; ++i) accumulate(work, i, prev, work.irr[i]);
    if (unbiased) {
        for (std::size_t i = 0; i < n; ++i) correction_[i] = work.chain[i];
        correction_dir_ = prev;
        correction_both_ = false;
        correction_scale_ = 1.0;
    }
}

void GlobalWalks::walk_combined(Work& work, bool both) {
    const std::size_t n = t_.patches();
    const int D = options_.depth;
    for (auto& v : work.table) std::fill(v.begin(), v.end(), Rgb::Zero());
    // Diffuse: work.table[b] is the running sum over the directions so far of the b-bounce
    // irradiance. Glossy: work.table[table_index(b, t)] the b-bounce irradiance whose last
    // direction was w_t.
    auto slot = [&](int b, int t) -> std::vector<Rgb>& { return glossy_ ? work.table[table_index(b, t)] : work.table[b]; };
    for (int t = 0; t < D; ++t) {
        const Vec3& w = work.dirs[t];
        const auto& matrix = work.matrices[t];
        const auto t0 = Clock::now();
        // Highest bounce first, so that (diffuse) the running sums still hold only the
        // directions before w_t.
        for (int b = t; b >= 1; --b) {
            for (std::size_t j = 0; j < n; ++j) {
                if (!glossy_) {
                    work.out[j] = t_.diffuse_reflectance(j) * work.table[b - 1][j];
                } else {
                    const Vec3 out = t_.departure(j, w, both);
                    Rgb sum = Rgb::Zero();
                    for (int s = b - 1; s < t; ++s) {
                        const Rgb& z = work.table[table_index(b - 1, s)][j];
                        if ((z != 0.0).any()) sum += t_.reflected(j, t_.arrival(j, work.dirs[s], both), out, z);
                    }
                    work.out[j] = sum;
                }
            }
            work.out[t_.sky_front()] = work.out[t_.sky_back()] = Rgb::Zero();
            t_.gather(matrix, work.out, slot(b, t), both, 1.0);
        }
        for (std::size_t j = 0; j < n; ++j) work.out[j] = walk_emission(j, t_.departure(j, w, both));
        t_.set_sky(w, work.out);
        t_.gather(matrix, work.out, slot(0, t), both, 1.0);
        work.seconds_transport += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    // Each b-bounce sample set: C(D, b+1) subsequences, times 2^(b+1) sign choices.
    std::vector<double> inv_samples(static_cast<std::size_t>(D));
    for (int b = 0; b < D; ++b)
        inv_samples[b] = 1.0 / (binomial(D, b + 1) * (both ? std::ldexp(1.0, b + 1) : 1.0));
    for (std::size_t i = 0; i < n; ++i) {
        if (!glossy_) {
            Rgb irr = Rgb::Zero();
            for (int b = 0; b < D; ++b) irr += inv_samples[b] * work.table[b][i];
            work.walk[i] += irr;
        } else {
            for (int t = 0; t < D; ++t)
                for (int b = 0; b <= t; ++b) {
                    const Rgb& z = work.table[table_index(b, t)][i];
                    if ((z != 0.0).any()) accumulate(work, i, t_.arrival(i, work.dirs[t], both), inv_samples[b] * z);
                }
        }
    }
    if (options_.unbiased) {
        // Bounce D-1 has one subsequence, ending at w_D.
        const auto& last = slot(D - 1, D - 1);
        for (std::size_t i = 0; i < n; ++i) correction_[i] = last[i];
        correction_dir_ = work.dirs[D - 1];
        correction_both_ = both;
        correction_scale_ = inv_samples[D - 1];
    }
}

void GlobalWalks::start_walk(Work& work, const double* point) {
    for (int d = 0; d < options_.depth; ++d) work.dirs[d] = sampling::uniform_sphere(point[2 * d], point[2 * d + 1]);
    draw_jitters(work);
}

void GlobalWalks::evaluate(Work& work, visibility::Backend* alone) {
    std::fill(work.walk.begin(), work.walk.end(), Rgb::Zero());
    transfer_all(work, alone);
    if (method_ == WalkMethod::walk)
        walk_plain(work);
    else
        walk_combined(work, method_ == WalkMethod::bidirectional);
}

double GlobalWalks::evaluate_at(const double* point) {
    Work& work = work_.front();
    start_walk(work, point);
    evaluate(work, nullptr);
    if (!source_->adapts()) return 0.0;
    double sum = 0.0;
    for (std::size_t p = 0; p < work.walk.size(); ++p) sum += luminance(weights_.weight[p] * work.walk[p]);
    return std::max(0.0, sum);
}

void GlobalWalks::grow_work(std::size_t walks) {
    if (work_.size() < walks) {
        const Work first = work_.front();  // a copy: resize() may move the vector
        work_.resize(walks, first);
    }
    // Each walk under way's vectors, the chain's sum, and an adapting source's own.
    report_.bytes_per_patch =
        (walk_vectors_ * work_.size() + 1 + (source_->adapts() ? source_->vectors() : 0)) * sizeof(Rgb);
}

std::optional<StepStream> GlobalWalks::stream(long total, bool shared) {
    if (!whole_walks_) return std::nullopt;  // one walk at a time (advance())
    // Whole walks side by side: a walk is proposed and its jitters drawn in walk order,
    // and its sum taken in walk order, so that the walks are those of one thread; a
    // thread free takes the next walk, up to walks_under_way() past the oldest not yet
    // summed (a slow walk does not hold the others up). Beside another chain's stream
    // even one backend keeps two walks under way, so that the other's threads can help.
    const int threads = backends_.threads();
    const std::size_t window = threads > 1 || shared ? static_cast<std::size_t>(walks_under_way(threads)) : 1;
    grow_work(window);
    StepStream s;
    s.count = std::max(0L, total);
    s.window = static_cast<long>(window);
    for (int t = 0; t < threads; ++t) s.backends.push_back(&backends_.at(t));
    const long base = walks_done_;
    s.begin = [this, base](long item, long slot) {
        source_->propose(base + item, point_.data());
        start_walk(work_[static_cast<std::size_t>(slot)], point_.data());
    };
    s.compute = [this](long slot, visibility::Backend& backend) { evaluate(work_[static_cast<std::size_t>(slot)], &backend); };
    const auto start = Clock::now();
    s.finish = [this, total, start](long item, long slot) {
        Work& work = work_[static_cast<std::size_t>(slot)];
        source_->accept(work.walk, 0.0, sum_);
        count(work);
        ++walks_done_;
        ++report_.steps;
        run_.report("solve", item + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
    };
    return s;
}

void GlobalWalks::advance(long total) {
    if (total <= 0) return;
    if (auto one = stream(total, false)) return run_step_stream(std::move(*one));
    // One walk at a time (its directions side by side on the backends, or in one batch).
    const auto start = Clock::now();
    for (long m = 0; m < total; ++m) {
        source_->propose(walks_done_, point_.data());
        const double importance = evaluate_at(point_.data());
        source_->accept(work_.front().walk, importance, sum_);
        count(work_.front());
        ++walks_done_;
        ++report_.steps;
        run_.report("solve", m + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
    }
}

// Between walks the sums, the jitters' generator, the correction and the source's
// state carry over (the walk's vectors start anew).
void GlobalWalks::save(StateWriter& out) const {
    out.tag(walk_method_name(method_));
    out.put(walks_done_);
    out.put(sum_);
    out.put(jitter_);
    out.put(correction_);
    out.put(correction_dir_);
    out.put(correction_both_);
    out.put(correction_scale_);
    out.tag(sampling::sampler_name(options_.sampler));
    source_->save(out);
    save_counters(out, report_);
}

void GlobalWalks::restore(StateReader& in) {
    in.expect(walk_method_name(method_));
    in.get(walks_done_);
    in.get(sum_);
    in.get(jitter_);
    in.get(correction_);
    in.get(correction_dir_);
    in.get(correction_both_);
    in.get(correction_scale_);
    in.expect(sampling::sampler_name(options_.sampler));
    source_->restore(in);
    restore_counters(in, report_);
}

RadianceField GlobalWalks::field(int threads) const {
    const WalkMean mean = source_->mean(sum_, walks_done_);
    if (threads <= 0) threads = run_.threads;
    if (mean.scale == 1.0) return t_.field_from(mean.sum, mean.count, to_eye_, threads);
    std::vector<Rgb> scaled = mean.sum;
    for (Rgb& v : scaled) v *= mean.scale;
    return t_.field_from(scaled, mean.count, to_eye_, threads);
}

}  // namespace raybundle::solver
