#include "solver/global_walks.h"

#include "sampling/streams.h"
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

constexpr int kVegasBins = 8;      // per direction, bins x bins over the unit square
constexpr long kVegasPhase = 64;   // walks between refinements
constexpr int kMetropolisChains = 4;
constexpr long kFirstRefresh = 16;       // Metropolis steps before the large steps' density is first learnt
constexpr double kRefreshGrowth = 1.25;  // then refreshed after 1.25 times as many
constexpr double kLearningShare = 0.2;   // of the steps after the seeds: learning, then the density is fixed

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
      sampler_(options.sampler, options.depth, run.seed, run.chain),
      jitter_(run.seed, sampling::streams::kMapJitters(run.chain, run.jitter_stream, 16)),
      adaptive_rng_(run.seed, sampling::streams::kAdaptiveWalks[run.chain]),
      vegas_(options.depth, kVegasBins),
      learner_(options.depth),
      exposure_(options.depth) {
    const std::size_t n = t_.patches(), slots = t_.slots();
    const int D = options.depth;
    dirs_.resize(static_cast<std::size_t>(D));
    out_.assign(slots, Rgb::Zero());
    sum_.assign(n, Rgb::Zero());
    walk_.assign(n, Rgb::Zero());
    std::size_t vectors = 3;  // out_, sum_ and walk_
    if (method == WalkMethod::walk) {
        irr_.assign(slots, Rgb::Zero());
        next_.assign(slots, Rgb::Zero());
        vectors += 2;
        if (options.unbiased) {
            chain_.assign(slots, Rgb::Zero());
            ++vectors;
        }
        report_.decisions["storage"] = "plain walk: the max-bounce irradiance" +
                                       std::string(options.unbiased ? " and the last-bounce chain (unbiased)" : "");
    } else {
        const std::size_t entries = glossy_ ? table_index(0, D) : static_cast<std::size_t>(D);
        table_.assign(entries, std::vector<Rgb>(slots, Rgb::Zero()));
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
    report_.bytes_per_patch = vectors * sizeof(Rgb);
    report_.details = {{"depth", D}, {"sampler", sampling::sampler_name(options.sampler)}, {"unbiased", options.unbiased}};
    if (glossy_) {
        to_eye_ = t_.directions_to_eye();
        report_.decisions["shading"] = "every walk, towards the eye (the scene has glossy materials)";
    } else {
        report_.decisions["shading"] = "once at the end (purely diffuse scene)";
    }
    if (sampling::adaptive(options.sampler)) {
        weights_ = importance_weights(t_, glossy_);
        point_.assign(static_cast<std::size_t>(2 * D), 0.0);
        proposal_ = point_;
        if (options.sampler == sampling::SamplerKind::metropolis) {
            chains_.assign(kMetropolisChains, Chain{point_, std::vector<Rgb>(n, Rgb::Zero()), 0.0, {}});
            seed_sum_.assign(n, Rgb::Zero());
            vectors += kMetropolisChains + 1;
        }
        report_.bytes_per_patch = vectors * sizeof(Rgb);
        report_.decisions["importance"] =
            "the image's luminance of a walk, from " + std::to_string(weights_.rays) + " camera rays (" +
            std::to_string(static_cast<int>(std::lround(100.0 * weights_.covered))) + " % meet a patch's front)";
    }
}

SolverReport GlobalWalks::report() const {
    SolverReport r = report_;
    if (options_.sampler == sampling::SamplerKind::vegas) {
        r.details["vegas"] = {{"bins", std::to_string(kVegasBins) + "x" + std::to_string(kVegasBins)},
                              {"phase_walks", kVegasPhase},
                              {"refinements", vegas_.refinements()}};
    } else if (options_.sampler == sampling::SamplerKind::metropolis) {
        r.details["metropolis"] = {{"chains", kMetropolisChains},
                                   {"mutation_size", options_.mutation_size},
                                   {"large_step", options_.large_step},
                                   {"seed_walks", seeds_done_},
                                   {"seeding", seeding_},
                                   {"exposure", exposure()},
                                   {"exposure_walks", exposure_.samples()},
                                   {"density_refreshes", exposure_.periods() - 1},
                                   {"learning_steps", learnt_},
                                   {"image_steps", imaged_},
                                   {"importance_floor", floor_},
                                   {"proposed", proposed_},
                                   {"acceptance_rate", proposed_ > 0 ? acceptance_sum_ / proposed_ : 0.0},
                                   {"accepted", proposed_ > 0 ? static_cast<double>(accepted_) / proposed_ : 0.0}};
    }
    if (sampling::adaptive(options_.sampler)) r.details["image_coverage"] = weights_.covered;
    return r;
}

void GlobalWalks::transfer_all() {
    jitters_.clear();
    for (std::size_t d = 0; d < dirs_.size(); ++d) jitters_.emplace_back(jitter_.uniform(), jitter_.uniform());
    const auto t0 = Clock::now();
    backends_.transfer_batch(dirs_, jitters_, matrices_);
    report_.seconds_visibility += std::chrono::duration<double>(Clock::now() - t0).count();
    for (const auto& m : matrices_) report_.entries_total += m.entries.size();
    report_.directions += static_cast<long>(matrices_.size());
}

Rgb GlobalWalks::walk_emission(std::size_t j, const Vec3& out) const {
    Rgb e = t_.emitted(j, out);
    if (correction_scale_ > 0.0)
        e += correction_scale_ * t_.reflected(j, t_.arrival(j, correction_dir_, correction_both_), out, correction_[j]);
    return e;
}

void GlobalWalks::accumulate(std::size_t i, const Vec3& arrived, const Rgb& irradiance) {
    if (glossy_)
        walk_[i] += t_.reflected(i, arrived, to_eye_[i], irradiance);
    else
        walk_[i] += irradiance;
}

void GlobalWalks::walk_plain() {
    const std::size_t n = t_.patches();
    const int D = options_.depth;
    const bool unbiased = options_.unbiased;
    std::fill(irr_.begin(), irr_.end(), Rgb::Zero());
    if (unbiased) std::fill(chain_.begin(), chain_.end(), Rgb::Zero());
    Vec3 prev = Vec3::Zero();
    for (int d = 0; d < D; ++d) {
        const Vec3& w = dirs_[d];
        const auto& matrix = matrices_[d];
        const auto t0 = Clock::now();
        // I <- A(w) (Le + C + 4 pi F I)
        for (std::size_t j = 0; j < n; ++j) {
            out_[j] = walk_emission(j, w);
            if (d > 0) out_[j] += t_.reflected(j, prev, w, irr_[j]);
        }
        t_.set_sky(w, out_);
        std::fill(next_.begin(), next_.end(), Rgb::Zero());
        t_.gather(matrix, out_, next_, false, 1.0);
        irr_.swap(next_);
        if (unbiased) {
            // J <- A(w) 4 pi F J, started from the emission (and sky): exactly d bounces.
            for (std::size_t j = 0; j < n; ++j)
                out_[j] = d == 0 ? walk_emission(j, w) : t_.reflected(j, prev, w, chain_[j]);
            if (d == 0)
                t_.set_sky(w, out_);
            else
                out_[t_.sky_front()] = out_[t_.sky_back()] = Rgb::Zero();
            std::fill(next_.begin(), next_.end(), Rgb::Zero());
            t_.gather(matrix, out_, next_, false, 1.0);
            chain_.swap(next_);
        }
        prev = w;
        report_.seconds_transport += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    for (std::size_t i = 0; i < n; ++i) accumulate(i, prev, irr_[i]);
    if (unbiased) {
        for (std::size_t i = 0; i < n; ++i) correction_[i] = chain_[i];
        correction_dir_ = prev;
        correction_both_ = false;
        correction_scale_ = 1.0;
    }
}

void GlobalWalks::walk_combined(bool both) {
    const std::size_t n = t_.patches();
    const int D = options_.depth;
    for (auto& v : table_) std::fill(v.begin(), v.end(), Rgb::Zero());
    // Diffuse: table_[b] is the running sum over the directions so far of the b-bounce
    // irradiance. Glossy: table_[table_index(b, t)] the b-bounce irradiance whose last
    // direction was w_t.
    auto slot = [&](int b, int t) -> std::vector<Rgb>& { return glossy_ ? table_[table_index(b, t)] : table_[b]; };
    for (int t = 0; t < D; ++t) {
        const Vec3& w = dirs_[t];
        const auto& matrix = matrices_[t];
        const auto t0 = Clock::now();
        // Highest bounce first, so that (diffuse) the running sums still hold only the
        // directions before w_t.
        for (int b = t; b >= 1; --b) {
            for (std::size_t j = 0; j < n; ++j) {
                if (!glossy_) {
                    out_[j] = t_.diffuse_reflectance(j) * table_[b - 1][j];
                } else {
                    const Vec3 out = t_.departure(j, w, both);
                    Rgb sum = Rgb::Zero();
                    for (int s = b - 1; s < t; ++s) {
                        const Rgb& z = table_[table_index(b - 1, s)][j];
                        if ((z != 0.0).any()) sum += t_.reflected(j, t_.arrival(j, dirs_[s], both), out, z);
                    }
                    out_[j] = sum;
                }
            }
            out_[t_.sky_front()] = out_[t_.sky_back()] = Rgb::Zero();
            t_.gather(matrix, out_, slot(b, t), both, 1.0);
        }
        for (std::size_t j = 0; j < n; ++j) out_[j] = walk_emission(j, t_.departure(j, w, both));
        t_.set_sky(w, out_);
        t_.gather(matrix, out_, slot(0, t), both, 1.0);
        report_.seconds_transport += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    // Each b-bounce sample set: C(D, b+1) subsequences, times 2^(b+1) sign choices.
    std::vector<double> inv_samples(static_cast<std::size_t>(D));
    for (int b = 0; b < D; ++b)
        inv_samples[b] = 1.0 / (binomial(D, b + 1) * (both ? std::ldexp(1.0, b + 1) : 1.0));
    for (std::size_t i = 0; i < n; ++i) {
        if (!glossy_) {
            Rgb irr = Rgb::Zero();
            for (int b = 0; b < D; ++b) irr += inv_samples[b] * table_[b][i];
            walk_[i] += irr;
        } else {
            for (int t = 0; t < D; ++t)
                for (int b = 0; b <= t; ++b) {
                    const Rgb& z = table_[table_index(b, t)][i];
                    if ((z != 0.0).any()) accumulate(i, t_.arrival(i, dirs_[t], both), inv_samples[b] * z);
                }
        }
    }
    if (options_.unbiased) {
        // Bounce D-1 has one subsequence, ending at w_D.
        const auto& last = slot(D - 1, D - 1);
        for (std::size_t i = 0; i < n; ++i) correction_[i] = last[i];
        correction_dir_ = dirs_[D - 1];
        correction_both_ = both;
        correction_scale_ = inv_samples[D - 1];
    }
}

void GlobalWalks::evaluate() {
    std::fill(walk_.begin(), walk_.end(), Rgb::Zero());
    transfer_all();
    if (method_ == WalkMethod::walk)
        walk_plain();
    else
        walk_combined(method_ == WalkMethod::bidirectional);
}

double GlobalWalks::evaluate_at(const double* point) {
    for (int d = 0; d < options_.depth; ++d) dirs_[d] = sampling::uniform_sphere(point[2 * d], point[2 * d + 1]);
    evaluate();
    return importance();
}

double GlobalWalks::importance() const {
    double sum = 0.0;
    for (std::size_t p = 0; p < walk_.size(); ++p) sum += luminance(weights_.weight[p] * walk_[p]);
    return std::max(0.0, sum);
}

void GlobalWalks::advance_vegas() {
    const double p = vegas_.sample(adaptive_rng_, point_.data());
    const double importance = evaluate_at(point_.data());
    for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += walk_[i] / p;
    vegas_.accumulate(point_.data(), importance / p);
    if (++phase_walks_ == kVegasPhase) {
        vegas_.refine();
        phase_walks_ = 0;
    }
}

long GlobalWalks::learning_steps() const {
    if (!(options_.large_step > 0.0)) return 0;  // nothing draws from the density
    return std::max(1L, static_cast<long>(kLearningShare * static_cast<double>(options_.steps - seed_target())));
}

long GlobalWalks::seed_target() const {
    if (options_.seed_walks > 0) return options_.seed_walks;
    return std::max(1L, static_cast<long>(SolverOptions::kAutoSeedShare * static_cast<double>(options_.steps)));
}

// One seed walk: a uniform walk, a sample of the exposure and of the seeds' field, and
// offered to every chain's reservoir (8.1.2's draw in proportion to the importance).
void GlobalWalks::seed_metropolis() {
    for (double& u : point_) u = adaptive_rng_.uniform();
    const double importance = evaluate_at(point_.data());
    for (std::size_t i = 0; i < seed_sum_.size(); ++i) seed_sum_[i] += walk_[i];
    exposure_.add(point_.data(), importance);
    ++seeds_done_;
    for (Chain& c : chains_) {
        // A walk that lights nothing is never picked: no random number spent on it.
        if (importance > 0.0 && c.seeds.offer(importance, adaptive_rng_.uniform())) {
            c.point = point_;
            c.estimate = walk_;
            c.importance = importance;
        }
    }
}

// The seeds are done (and one of them brought light to the image): the floor, and the
// chains' first walks are their picks.
void GlobalWalks::start_chains() {
    floor_ = 0.01 * exposure_.mean();
    for (Chain& c : chains_) c.importance += floor_;
    next_refresh_ = kFirstRefresh;
    seeding_ = false;
}

void GlobalWalks::advance_metropolis() {
    if (seeding_) {
        // Where the image is lit through a small opening every seed may miss it: the
        // seeding goes on until one brings light to the image (in a scene whose image
        // stays dark, the whole run is uniform walks).
        seed_metropolis();
        if (seeds_done_ >= seed_target() && exposure_.mean() > 0.0) start_chains();
        return;
    }
    Chain& c = chains_[static_cast<std::size_t>(proposed_ % kMetropolisChains)];
    const int size = 2 * options_.depth;
    // A large step draws the walk anew from the learnt density p (sampling/mixture.h):
    // an independence proposal, accepted by the Metropolis-Hastings ratio
    // I(z') p(z) / (I(z) p(z')). A small step perturbs the walk (symmetric).
    const bool large = adaptive_rng_.uniform() < options_.large_step;
    double proposal_over_current = 1.0;  // p(z') / p(z) for a large step
    if (large) {
        const sampling::DirectionMixture& p = exposure_.current();
        proposal_over_current = p.sample(adaptive_rng_, proposal_.data()) / p.density(c.point.data());
    } else {
        sampling::Mutation{options_.mutation_size}(c.point.data(), proposal_.data(), size, adaptive_rng_);
    }
    const double raw = evaluate_at(proposal_.data()), importance = raw + floor_;
    if (large) exposure_.add(proposal_.data(), raw);  // an independent walk: a sample of b
    const double a = std::min(1.0, importance / (c.importance * proposal_over_current));
    if (learnt_ < learning_steps()) {
        // Learning: the density learns from the step's expected value (both walks,
        // weighed by a) and is refreshed now and then; the step stays out of the image.
        learner_.learn(proposal_.data(), a);
        learner_.learn(c.point.data(), 1.0 - a);
        ++learnt_;
        if (learnt_ == next_refresh_ || learnt_ == learning_steps()) {
            exposure_.draw_from(learner_.mixture(), std::sqrt(1.0 + static_cast<double>(learnt_)));
            next_refresh_ = std::max(next_refresh_ + 1, static_cast<long>(kRefreshGrowth * static_cast<double>(next_refresh_)));
        }
    } else {
        // The expected value of the step (004 section 8.2): both walks, weighed by a;
        // the exposure b multiplies the sum when it is read (field()).
        const double new_weight = a / importance, old_weight = (1.0 - a) / c.importance;
        for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += new_weight * walk_[i] + old_weight * c.estimate[i];
        ++imaged_;
    }
    ++proposed_;
    acceptance_sum_ += a;
    if (adaptive_rng_.uniform() < a) {
        c.point = proposal_;
        c.estimate.swap(walk_);
        c.importance = importance;
        ++accepted_;
    }
}

void GlobalWalks::advance(long total) {
    const auto start = Clock::now();
    for (long m = 0; m < total; ++m) {
        if (options_.sampler == sampling::SamplerKind::vegas) {
            advance_vegas();
        } else if (options_.sampler == sampling::SamplerKind::metropolis) {
            advance_metropolis();
        } else {
            sampler_.start_walk(static_cast<std::uint64_t>(walks_done_));
            for (int d = 0; d < options_.depth; ++d) dirs_[d] = sampler_.direction(d);
            evaluate();
            for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += walk_[i];
        }
        ++walks_done_;
        ++report_.steps;
        run_.report("solve", m + 1, total, std::chrono::duration<double>(Clock::now() - start).count());
    }
}

// Between walks only the sums, the jitters' generator and the correction carry over
// (the sampler gives walk m from m alone; the walk's vectors start anew).
void GlobalWalks::save(StateWriter& out) const {
    out.tag(walk_method_name(method_));
    out.put(walks_done_);
    out.put(sum_);
    out.put(jitter_);
    out.put(correction_);
    out.put(correction_dir_);
    out.put(correction_both_);
    out.put(correction_scale_);
    if (sampling::adaptive(options_.sampler)) {
        out.tag(sampling::sampler_name(options_.sampler));
        out.put(adaptive_rng_);
        out.put(floor_);
        out.put(vegas_.weights());
        out.put(vegas_.sums());
        out.put(vegas_.refinements());
        out.put(phase_walks_);
        out.put(seeds_done_);
        out.put(seeding_);
        out.put(seed_sum_);
        for (const Chain& c : chains_) {
            out.put(c.point);
            out.put(c.estimate);
            out.put(c.importance);
            out.put(c.seeds.total);
        }
        out.put(learner_.counts());
        out.put(learner_.totals());
        out.put(learner_.marginals());
        out.put(learner_.marginal_total());
        out.put(learnt_);
        out.put(next_refresh_);
        out.put(imaged_);
        out.put(exposure_.current().uniform);
        out.put(exposure_.current().weights);
        out.put(exposure_.current().cells);
        out.put(exposure_.trust());  // its count first, which restore() bounds before allocating
        out.put(exposure_.counts());
        out.put(exposure_.sums());
        out.put(proposed_);
        out.put(accepted_);
        out.put(acceptance_sum_);
    }
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
    if (sampling::adaptive(options_.sampler)) {
        in.expect(sampling::sampler_name(options_.sampler));
        in.get(adaptive_rng_);
        in.get(floor_);
        const std::size_t cells = vegas_.weights().size();
        in.get(vegas_.weights());
        in.get(vegas_.sums());
        if (vegas_.weights().size() != cells || vegas_.sums().size() != cells)
            throw StateError("VEGAS tables of another depth");
        in.get(vegas_.refinements());
        vegas_.update_cdf();
        in.get(phase_walks_);
        in.get(seeds_done_);
        in.get(seeding_);
        in.get(seed_sum_);  // the reader checks the sizes, here and below
        for (Chain& c : chains_) {
            in.get(c.point);
            in.get(c.estimate);
            in.get(c.importance);
            in.get(c.seeds.total);
        }
        in.get(learner_.counts());
        in.get(learner_.totals());
        in.get(learner_.marginals());
        in.get(learner_.marginal_total());
        in.get(learnt_);
        in.get(next_refresh_);
        in.get(imaged_);
        sampling::DirectionMixture& p = exposure_.current();
        in.get(p.uniform);
        in.get(p.weights);
        in.get(p.cells);
        if (!p.valid(options_.depth)) throw StateError("a Metropolis density out of range");
        std::uint64_t periods = 0;
        in.get(periods);
        // Each period takes 24 bytes: a count the bytes left cannot hold is refused
        // before anything is allocated.
        if (periods < 1 || periods > in.left() / 24) throw StateError("a Metropolis period count out of range");
        exposure_.trust().resize(periods);
        exposure_.counts().resize(periods);
        exposure_.sums().resize(periods);
        for (std::uint64_t k = 0; k < periods; ++k) {
            in.get(exposure_.trust()[k]);
            if (!(exposure_.trust()[k] > 0.0)) throw StateError("a Metropolis trust out of range");
        }
        in.get(exposure_.counts());
        in.get(exposure_.sums());
        for (const Chain& c : chains_)
            for (double u : c.point)
                if (!(u >= 0.0 && u <= 1.0)) throw StateError("a Metropolis walk outside the unit cube");
        in.get(proposed_);
        in.get(accepted_);
        in.get(acceptance_sum_);
    }
    restore_counters(in, report_);
}

RadianceField GlobalWalks::field() const {
    if (options_.sampler != sampling::SamplerKind::metropolis) return t_.field_from(sum_, walks_done_, to_eye_);
    if (imaged_ == 0) return t_.field_from(seed_sum_, seeds_done_, to_eye_);
    std::vector<Rgb> scaled = sum_;
    for (Rgb& v : scaled) v *= exposure();
    return t_.field_from(scaled, imaged_, to_eye_);
}

double GlobalWalks::exposure() const {
    return exposure_.samples() > 0 ? exposure_.mean() + floor_ : 0.0;
}

}  // namespace raybundle::solver
