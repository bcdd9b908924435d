#pragma once
// A learnt density over walks, for the Metropolis sampler's large steps and its
// exposure (docs/importance-sampling.md). A walk of D directions is a point z of
// [0,1)^(2D), direction t at coordinates 2t, 2t+1 (sampling/adaptive.h).
//
// In the scenes where importance sampling matters the light that reaches the image
// usually hangs on one direction of the walk at a time: light from the next room
// reaches the camera's room when some w_t passes through the opening, whichever t it
// is and whatever the others are. A separable density (VEGAS) cannot say "one of the
// D directions in the cone": its product puts the cone in every factor at once, or
// in none. A mixture of one-direction components can:
//
//     p(z) = u + (1 - u) sum_t c_t h_t(w_t)
//
// u the defensive uniform share (Hesterberg: 1/p stays below 1/u), c_t the weight
// of component t (sum 1), h_t a density over direction t's two coordinates, B x B
// cells of equal area (uniform_sphere keeps areas), the other directions uniform.
//
//   DirectionMixture  the density: p(z), and draws from it.
//   MixtureLearner    learns c_t and h_t from points of the target distribution (the
//                     chains' walks): a point's responsibilities r_t, how much more
//                     often than uniform the points so far had direction t in the
//                     point's cell, add r_t / sum r times its weight to component t's
//                     cell (spread over its 3 x 3 neighbours) and to c_t. Each
//                     component thus takes the points its direction explains: the
//                     walks lit through the opening by w_3 sharpen h_3, not h_1.
//   MixtureEstimate   the integral of f >= 0 over the cube from independent samples
//                     drawn from a sequence of densities p_1..p_K, n_k samples from
//                     p_k (the uniform density is one): each density's own estimate
//                     sum f / p_k, weighed by a trust omega_k fixed before its samples
//                     are drawn,
//                         sum_k omega_k sum_{i from p_k} f(z_i) / p_k(z_i)  /  sum_k omega_k n_k.
//                     Every summand has the expectation omega_k * integral whatever
//                     p_k is (it was learnt from earlier samples only) and the weights
//                     do not look at the values, so the estimate is unbiased (given
//                     the samples' counts: the solver's seeding, which goes on while
//                     the image is dark, is the exception). (The
//                     deterministic mixture, which weighs every sample by the mixture
//                     of all the densities, bounds the weights further, but a density
//                     learnt near a sample then discounts that sample: it measured 28 %
//                     low on the homogeneous box.)
//
// All deterministic given their random generator and the order of their inputs.
#include "sampling/rng.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <utility>
#include <vector>

namespace raybundle::sampling {

struct DirectionMixture {
    static constexpr int kBins = 32;          // B: 1024 cells of 0.0123 sr
    static constexpr double kUniform = 0.25;  // u of a learnt mixture

    int directions = 1;
    double uniform = 1.0;         // u; 1: the uniform density
    std::vector<double> weights;  // c_t, D of them
    std::vector<double> cells;    // h_t per cell, B x B per component (mean 1 over a component)

    static constexpr int cells_per_component() { return kBins * kBins; }

    // The uniform density over D directions.
    static DirectionMixture uniform_density(int directions) {
        if (directions < 1) throw std::invalid_argument("DirectionMixture: directions must be >= 1");
        DirectionMixture m;
        m.directions = directions;
        m.weights.assign(static_cast<std::size_t>(directions), 1.0 / directions);
        m.cells.assign(static_cast<std::size_t>(directions) * cells_per_component(), 1.0);
        return m;
    }

    // The cell of a direction's coordinates in [0, 1] (1 goes to the last cell).
    static int cell_of(const double* uv) {
        const int i = std::clamp(static_cast<int>(uv[0] * kBins), 0, kBins - 1);
        const int j = std::clamp(static_cast<int>(uv[1] * kBins), 0, kBins - 1);
        return i * kBins + j;
    }

    // Whether restored values make a density: 0 < u <= 1, weights and cells finite
    // and >= 0, of the sizes for `directions`.
    bool valid(int directions_expected) const {
        auto ok = [](double v) { return std::isfinite(v) && v >= 0.0; };
        if (directions != directions_expected || !(uniform > 0.0 && uniform <= 1.0)) return false;
        if (weights.size() != static_cast<std::size_t>(directions) ||
            cells.size() != static_cast<std::size_t>(directions) * cells_per_component())
            return false;
        return std::all_of(weights.begin(), weights.end(), ok) && std::all_of(cells.begin(), cells.end(), ok);
    }

    double density(const double* point) const {
        double p = 0.0;
        for (int t = 0; t < directions; ++t)
            p += weights[t] * cells[static_cast<std::size_t>(t) * cells_per_component() + cell_of(point + 2 * t)];
        return uniform + (1.0 - uniform) * p;
    }

    // Draws z (2 D coordinates into `point`); returns p(z).
    double sample(Rng& rng, double* point) const {
        for (int k = 0; k < 2 * directions; ++k) point[k] = rng.uniform();
        const double r = rng.uniform();
        if (r >= uniform) {
            // Component t by c_t, then its cell by h_t (a running sum: 1024 cells cost
            // nothing next to the walk's D visibility passes).
            double x = (r - uniform) / (1.0 - uniform);
            int t = 0;
            while (t < directions - 1 && x >= weights[t]) x -= weights[t++];
            const double* h = &cells[static_cast<std::size_t>(t) * cells_per_component()];
            double y = rng.uniform() * cells_per_component();
            int cell = 0;
            while (cell < cells_per_component() - 1 && (y -= h[cell]) >= 0.0) ++cell;
            point[2 * t] = (cell / kBins + rng.uniform()) / kBins;
            point[2 * t + 1] = (cell % kBins + rng.uniform()) / kBins;
        }
        return density(point);
    }
};

class MixtureLearner {
public:
    // Each cell starts with kPrior points, each component with one: a cell no point
    // has reached keeps a little density, and the first points cannot empty the rest.
    static constexpr double kPrior = 0.02;

    explicit MixtureLearner(int directions)
        : directions_(checked(directions)),
          counts_(static_cast<std::size_t>(directions) * DirectionMixture::cells_per_component(), 0.0),
          totals_(static_cast<std::size_t>(directions), 0.0),
          marginals_(static_cast<std::size_t>(directions) * DirectionMixture::cells_per_component(), 0.0),
          responsibility_(static_cast<std::size_t>(directions)),
          cell_(static_cast<std::size_t>(directions)) {
    }

    // One point of the target with weight w >= 0.
    void learn(const double* point, double w) {
        if (!(w > 0.0)) return;
        const int per = DirectionMixture::cells_per_component();
        double sum = 0.0;
        // The responsibilities: how much more often than uniform the points so far had
        // this direction in this cell (the plain marginals, which every point feeds
        // whole: responsibilities from the components themselves would reinforce
        // whatever the first points happened to give them).
        const double cells = per;
        for (int t = 0; t < directions_; ++t) {
            cell_[t] = DirectionMixture::cell_of(point + 2 * t);
            responsibility_[t] =
                cells * (marginals_[static_cast<std::size_t>(t) * per + cell_[t]] + kPrior) / (marginal_total_ + kPrior * cells);
            sum += responsibility_[t];
        }
        marginal_total_ += w;
        for (int t = 0; t < directions_; ++t) {
            spread(&marginals_[static_cast<std::size_t>(t) * per], cell_[t], w);
            const double share = w * responsibility_[t] / sum;
            spread(&counts_[static_cast<std::size_t>(t) * per], cell_[t], share);
            totals_[t] += share;
        }
    }

    // What was learnt, with the defensive share kUniform.
    DirectionMixture mixture() const {
        DirectionMixture m = DirectionMixture::uniform_density(directions_);
        m.uniform = DirectionMixture::kUniform;
        for (int t = 0; t < directions_; ++t) {
            m.weights[t] = weight(t);
            for (int c = 0; c < DirectionMixture::cells_per_component(); ++c)
                m.cells[static_cast<std::size_t>(t) * DirectionMixture::cells_per_component() + c] = cell_density(t, c);
        }
        return m;
    }

    // The state a checkpoint keeps (solver/state.h).
    std::vector<double>& counts() { return counts_; }
    std::vector<double>& totals() { return totals_; }
    std::vector<double>& marginals() { return marginals_; }
    double& marginal_total() { return marginal_total_; }
    const std::vector<double>& counts() const { return counts_; }
    const std::vector<double>& totals() const { return totals_; }
    const std::vector<double>& marginals() const { return marginals_; }
    double marginal_total() const { return marginal_total_; }

private:
    static int checked(int directions) {
        if (directions < 1) throw std::invalid_argument("MixtureLearner: directions must be >= 1");
        return directions;
    }
    double weight(int t) const {
        double all = 0.0;
        for (double v : totals_) all += v;
        return (totals_[t] + 1.0) / (all + directions_);
    }
    double cell_density(int t, int c) const {
        const double per = DirectionMixture::cells_per_component();
        return per * (counts_[static_cast<std::size_t>(t) * DirectionMixture::cells_per_component() + c] + kPrior) /
               (totals_[t] + kPrior * per);
    }

    // Adds `share` around `cell`: its 3 x 3 neighbours with Lepage's (1, 6, 1) / 8 in
    // each coordinate (wrapping in phi, not over the poles).
    static void spread(double* counts, int cell, double share) {
        constexpr double kWeight[3] = {1.0, 6.0, 1.0};
        const int i = cell / DirectionMixture::kBins, j = cell % DirectionMixture::kBins;
        double norm = 0.0;
        for (int di = -1; di <= 1; ++di)
            if (i + di >= 0 && i + di < DirectionMixture::kBins) norm += kWeight[di + 1] * 8.0;
        for (int di = -1; di <= 1; ++di) {
            const int ii = i + di;
            if (ii < 0 || ii >= DirectionMixture::kBins) continue;
            for (int dj = -1; dj <= 1; ++dj) {
                const int jj = (j + dj + DirectionMixture::kBins) % DirectionMixture::kBins;
                counts[ii * DirectionMixture::kBins + jj] += share * kWeight[di + 1] * kWeight[dj + 1] / norm;
            }
        }
    }
    int directions_;
    std::vector<double> counts_;  // per component, B x B
    std::vector<double> totals_;  // per component: the weight it took
    std::vector<double> marginals_;  // per direction, B x B: every point's whole weight
    double marginal_total_ = 0.0;
    std::vector<double> responsibility_;
    std::vector<int> cell_;
};

class MixtureEstimate {
public:
    // Starts with the uniform density, trust 1.
    explicit MixtureEstimate(int directions) : current_(DirectionMixture::uniform_density(directions)) {
        begin_period(1.0);
    }

    // The next samples are drawn from `p`; their trust `omega` > 0 (fixed before they
    // are drawn).
    void draw_from(DirectionMixture p, double omega) {
        current_ = std::move(p);
        begin_period(omega);
    }
    const DirectionMixture& current() const { return current_; }

    // A sample drawn from current(): its point and f(z) >= 0.
    void add(const double* point, double f) {
        ++counts_.back();
        if (f > 0.0) sums_.back() += f / current_.density(point);
    }

    long samples() const {
        long n = 0;
        for (long c : counts_) n += c;
        return n;
    }
    long periods() const { return static_cast<long>(counts_.size()); }  // densities drawn from

    // The estimate of the integral (0 before the first sample).
    double mean() const {
        double sum = 0.0, weight = 0.0;
        for (std::size_t k = 0; k < sums_.size(); ++k) {
            sum += trust_[k] * sums_[k];
            weight += trust_[k] * static_cast<double>(counts_[k]);
        }
        return weight > 0.0 ? sum / weight : 0.0;
    }

    // The state a checkpoint keeps (solver/state.h): the current density and, per
    // period, omega_k, n_k and the sum of f / p_k.
    DirectionMixture& current() { return current_; }
    std::vector<double>& trust() { return trust_; }
    std::vector<long>& counts() { return counts_; }
    std::vector<double>& sums() { return sums_; }
    const std::vector<double>& trust() const { return trust_; }
    const std::vector<long>& counts() const { return counts_; }
    const std::vector<double>& sums() const { return sums_; }

private:
    void begin_period(double omega) {
        if (!(omega > 0.0)) throw std::invalid_argument("MixtureEstimate: a trust must be > 0");
        trust_.push_back(omega);
        counts_.push_back(0);
        sums_.push_back(0.0);
    }

    DirectionMixture current_;
    std::vector<double> trust_;  // omega_k
    std::vector<long> counts_;   // n_k
    std::vector<double> sums_;   // sum of f / p_k over the samples from p_k
};

}  // namespace raybundle::sampling
