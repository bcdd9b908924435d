#pragma once
// Importance sampling of global walks (004 section 7): a walk of D directions is a
// point z of the unit cube [0,1)^(2D) (sampling/walk_sampler.h: coordinates 2d, 2d+1
// give direction d through uniform_sphere, which keeps areas: a region of the square
// is the same share of the sphere), and the walks that matter are those whose light
// reaches the image. Two adaptive ways to prefer them:
//
//   VegasTables  (004 section 7.1, after Lepage's VEGAS) a separable density
//                p(z) = g_1(w_1) ... g_D(w_D), each g_d a table of B x B bins over the
//                square; an estimate divides by p(z) (eq. 33), so it stays unbiased
//                for any tables. The tables are refined in phases from the importance
//                of the phase's samples (eq. 35-36; choices below).
//   Mutation     (004 section 8.1.1) the Metropolis small step: a uniform perturbation
//                of every coordinate within [-delta/2, delta/2) on the circle (a
//                coordinate that leaves [0,1) comes back on the other side: 004 section
//                8.4 treats the domain as circular). Symmetric: T(x -> y) = T(y -> x).
//                The large steps, independent draws that keep the chain from staying
//                in one mode, come from a learnt density (sampling/mixture.h).
//
// Both are deterministic given their random generator.
#include "sampling/rng.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::sampling {

class VegasTables {
public:
    // Refinement, after Lepage (J. Comput. Phys. 27, 1978): a bin's target weight is the
    // square root of its share of sum (I/p)^2 p_d (eq. 35: the optimal g_d is the root
    // of the integral of I^2 / (the other factors) over the other directions; eq. 36 its
    // estimate from the samples so far), smoothed over its 3 x 3 neighbours with
    // Lepage's weights (1, 6, 1) / 8 in each coordinate (wrapping around in phi); damped: the new
    // table is the mean of the old one and the target (Lepage damps the rebinning so
    // that one phase's noise cannot empty a region; this is the same for fixed bins);
    // and floored: every bin keeps `kFloor` of its uniform weight, so that a region
    // the samples have not yet shown to matter can still be found.
    // The density is the tables' product mixed with the uniform density, a share
    // kDefensive of the samples uniform (Hesterberg's defensive importance sampling):
    // 1/p stays below 1/kDefensive however the tables concentrate, where a floor per
    // table would compound over the D factors (0.1^D).
    static constexpr double kDamping = 0.5;
    static constexpr double kFloor = 0.02;
    static constexpr double kDefensive = 0.2;

    VegasTables(int factors, int bins) : factors_(factors), bins_(bins) {
        if (factors < 1 || bins < 1) throw std::invalid_argument("VegasTables: factors and bins must be >= 1");
        const std::size_t cells = static_cast<std::size_t>(factors) * bins * bins;
        weights_.assign(cells, 1.0 / (static_cast<double>(bins) * bins));
        sums_.assign(cells, 0.0);
        cdf_.resize(cells);
        update_cdf();
    }

    int factors() const { return factors_; }
    int bins() const { return bins_; }
    long refinements() const { return refinements_; }

    // Draws z (2 factors() coordinates into `point`) from the density; returns p(z).
    double sample(Rng& rng, double* point) const {
        const bool uniform = rng.uniform() < kDefensive;
        const std::size_t per = cells_per_factor();
        for (int d = 0; d < factors_; ++d) {
            const double* cdf = &cdf_[d * per];
            const double r = rng.uniform();
            const std::size_t cell =
                uniform ? std::min<std::size_t>(per - 1, static_cast<std::size_t>(r * static_cast<double>(per)))
                        : std::min<std::size_t>(per - 1, static_cast<std::size_t>(std::upper_bound(cdf, cdf + per, r) - cdf));
            const double a = rng.uniform(), b = rng.uniform();
            point[2 * d] = (static_cast<double>(cell / bins_) + a) / bins_;
            point[2 * d + 1] = (static_cast<double>(cell % bins_) + b) / bins_;
        }
        return density(point);
    }

    // p(z) of a point: the tables' product, mixed with the uniform density.
    double density(const double* point) const { return (1.0 - kDefensive) * product(point) + kDefensive; }

    // A sample: its point and importance / density; (importance / density)^2 times the
    // factor's density is the summand of the refinement (eq. 36).
    void accumulate(const double* point, double importance_over_density) {
        // The product's share of the density (eq. 35 is about the product's factors).
        const double w = importance_over_density * importance_over_density;
        if (!(w > 0.0) || !std::isfinite(w)) return;
        for (int d = 0; d < factors_; ++d) {
            const std::size_t cell = cell_of(point + 2 * d);
            sums_[d * cells_per_factor() + cell] += w * factor_density(d, cell);
        }
    }

    // Ends a phase: refines every factor that saw importance. The sums run on over the
    // phases (each sample's summand is divided by the density it was drawn from, so
    // all phases estimate the same integral of eq. 35): a phase of a few dozen walks
    // alone would leave most bins empty.
    void refine() {
        const std::size_t per = cells_per_factor();
        std::vector<double> smooth(per);
        for (int d = 0; d < factors_; ++d) {
            double* sums = &sums_[d * per];
            double* g = &weights_[d * per];
            double total = 0.0;
            for (std::size_t c = 0; c < per; ++c) total += sums[c];
            if (total > 0.0) {
                // Lepage's (1, 6, 1) / 8 in each of the two coordinates.
                constexpr double kWeight[3] = {1.0, 6.0, 1.0};
                for (int i = 0; i < bins_; ++i)
                    for (int j = 0; j < bins_; ++j) {
                        double s = 0.0, n = 0.0;
                        for (int di = -1; di <= 1; ++di) {
                            const int ii = i + di;
                            if (ii < 0 || ii >= bins_) continue;  // theta: no wrap at the poles
                            for (int dj = -1; dj <= 1; ++dj) {
                                const double w = kWeight[di + 1] * kWeight[dj + 1];
                                s += w * std::sqrt(sums[ii * bins_ + (j + dj + bins_) % bins_]);
                                n += w;
                            }
                        }
                        smooth[static_cast<std::size_t>(i) * bins_ + j] = s / n;
                    }
                double share_total = 0.0;
                for (double v : smooth) share_total += v;
                const double uniform = 1.0 / static_cast<double>(per);
                for (std::size_t c = 0; c < per; ++c) {
                    const double target = (1.0 - kFloor) * smooth[c] / share_total + kFloor * uniform;
                    g[c] = (1.0 - kDamping) * g[c] + kDamping * target;
                }
            }
        }
        ++refinements_;
        update_cdf();
    }

    // The state a checkpoint keeps (solver/state.h).
    std::vector<double>& weights() { return weights_; }
    std::vector<double>& sums() { return sums_; }
    const std::vector<double>& weights() const { return weights_; }
    const std::vector<double>& sums() const { return sums_; }
    long& refinements() { return refinements_; }
    void update_cdf() {
        const std::size_t per = cells_per_factor();
        for (int d = 0; d < factors_; ++d) {
            double run = 0.0, total = 0.0;
            for (std::size_t c = 0; c < per; ++c) total += weights_[d * per + c];
            for (std::size_t c = 0; c < per; ++c) cdf_[d * per + c] = (run += weights_[d * per + c]) / total;
            cdf_[d * per + per - 1] = 1.0;
        }
    }

private:
    double product(const double* point) const {
        double p = 1.0;
        for (int d = 0; d < factors_; ++d) p *= factor_density(d, cell_of(point + 2 * d));
        return p;
    }
    std::size_t cells_per_factor() const { return static_cast<std::size_t>(bins_) * bins_; }
    std::size_t cell_of(const double* uv) const {
        const auto i = std::min(bins_ - 1, static_cast<int>(uv[0] * bins_));
        const auto j = std::min(bins_ - 1, static_cast<int>(uv[1] * bins_));
        return static_cast<std::size_t>(i) * bins_ + j;
    }
    // The density of factor d in a cell: its weight over the cell's area.
    double factor_density(int d, std::size_t cell) const {
        return weights_[d * cells_per_factor() + cell] * static_cast<double>(cells_per_factor());
    }

    int factors_, bins_;
    std::vector<double> weights_, sums_, cdf_;  // per factor, bins x bins (theta-major)
    long refinements_ = 0;
};

// The Metropolis small step (above): `size` coordinates perturbed by delta.
struct Mutation {
    double delta = 0.1;

    void operator()(const double* from, double* to, int size, Rng& rng) const {
        for (int k = 0; k < size; ++k) {
            double u = from[k] + delta * (rng.uniform() - 0.5);
            u -= std::floor(u);
            to[k] = u >= 1.0 ? 0.0 : u;
        }
    }
};

// A pick in proportion to weight from a stream of items, in one pass (a weighted
// reservoir of one: the seeds of 004 section 8.1.2). Item k replaces the pick with
// probability w_k / (w_1 + ... + w_k), so after n items the pick is item k with
// probability w_k / (w_1 + ... + w_n). `u` uniform in [0, 1).
struct Reservoir {
    double total = 0.0;  // the weight offered so far

    // Returns whether the item of weight `weight` (>= 0) becomes the pick.
    bool offer(double weight, double u) {
        total += weight;
        return weight > 0.0 && u * total < weight;
    }
};

}  // namespace raybundle::sampling
