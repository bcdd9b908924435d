#pragma once
// Direction samplers for global walks (004 section 4.1): one walk of D directions is
// one point of a 2D-dimensional sequence, dimensions (2d, 2d+1) giving direction d
// through uniform_sphere().
//
//   random  independent uniform points (xoshiro256**, one stream per walk)
//   halton  the Halton sequence (bases: the first 2D primes), scrambled by a random
//           permutation of the digits per dimension (which breaks the correlation
//           between the high bases at small counts), then randomised by a
//           Cranley-Patterson rotation (one uniform shift per dimension and run)
//   sobol   the Sobol sequence (Joe-Kuo direction numbers, up to 30 dimensions),
//           randomised by a random digital shift (one XOR mask per dimension and run).
//           Direction d takes the pair of Sobol dimensions detail::kSobolOrder[2d],
//           [2d + 1], not dimensions 2d and 2d + 1: a direction is a 2-D point on the
//           sphere, and some Joe-Kuo pairs are poor 2-D nets at small counts (dimensions
//           8 and 9, direction 5 of a walk in plain order, fill half of a 16 x 16 grid
//           with the first 512 points; the last direction decides what each patch
//           receives, and a run's two chains of 500 walks each were 2x worse than
//           random). The pairs of the first nine directions are (t, m, 2)-nets with
//           t <= 2 for every m <= 12 (tests/sampling/test_walk_sampler.cpp).
//
// The randomisation makes every walk uniformly distributed, so each run is an
// unbiased estimate and independent seeds give an error estimate; the points of one
// run stay low-discrepancy.
//
// Call order: WalkSampler(kind, depth, seed, chain); then for each walk m = 0, 1, 2, ...:
// start_walk(m), followed by direction(0) ... direction(D-1) (any order; each is a
// pure function of (seed, m, d)). Walks may be visited in any order: walk m is the
// same points whatever came before it.
//
// Not for stochastic iteration: its proof (004 section 4.4) needs consecutive
// directions to be independent, and consecutive points of a low-discrepancy sequence
// are strongly correlated (see solver/stochastic_iteration.h).
#include "sampling/directions.h"
#include "sampling/rng.h"
#include "sampling/streams.h"

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::sampling {

// vegas and metropolis adapt to the image (sampling/adaptive.h, solver/walk_source.h):
// they draw their points themselves, WalkSampler refuses them.
enum class SamplerKind { random, halton, sobol, vegas, metropolis };

// The samplers' names in the enum's order: one list for parsing, messages and the
// command line's choices.
inline constexpr std::array<const char*, 5> kSamplerNames = {"random", "halton", "sobol", "vegas", "metropolis"};

inline const char* sampler_name(SamplerKind k) { return kSamplerNames[static_cast<std::size_t>(k)]; }

// Parses a sampler's name; throws std::invalid_argument listing them.
inline SamplerKind parse_sampler(const std::string& name) {
    std::string known;
    for (std::size_t k = 0; k < kSamplerNames.size(); ++k) {
        if (name == kSamplerNames[k]) return static_cast<SamplerKind>(k);
        known += (k > 0 ? ", " : "") + std::string(kSamplerNames[k]);
    }
    throw std::invalid_argument("unknown sampler '" + name + "' (known: " + known + ")");
}

inline bool adaptive(SamplerKind k) { return k == SamplerKind::vegas || k == SamplerKind::metropolis; }

namespace detail {

// The first primes: Halton bases for up to 64 dimensions (walks up to D = 32).
inline constexpr std::array<unsigned, 64> kPrimes = {
    2,   3,   5,   7,   11,  13,  17,  19,  23,  29,  31,  37,  41,  43,  47,  53,  59,  61,  67,  71,  73,  79,
    83,  89,  97,  101, 103, 107, 109, 113, 127, 131, 137, 139, 149, 151, 157, 163, 167, 173, 179, 181, 191, 193,
    197, 199, 211, 223, 227, 229, 233, 239, 241, 251, 257, 263, 269, 271, 277, 281, 283, 293, 307, 311};

// Joe and Kuo's direction numbers (new-joe-kuo-6.21201) for dimensions 2..30:
// degree s of the primitive polynomial, its coefficients a, and the initial m_k.
struct SobolPolynomial {
    unsigned s, a;
    std::array<std::uint32_t, 7> m;
};
inline constexpr std::array<SobolPolynomial, 29> kSobol = {{
    {1, 0, {1}},
    {2, 1, {1, 3}},
    {3, 1, {1, 3, 1}},
    {3, 2, {1, 1, 1}},
    {4, 1, {1, 1, 3, 3}},
    {4, 4, {1, 3, 5, 13}},
    {5, 2, {1, 1, 5, 5, 17}},
    {5, 4, {1, 1, 5, 5, 5}},
    {5, 7, {1, 1, 7, 11, 19}},
    {5, 11, {1, 1, 5, 1, 1}},
    {5, 13, {1, 1, 1, 3, 11}},
    {5, 14, {1, 3, 5, 5, 31}},
    {6, 1, {1, 3, 3, 9, 7, 49}},
    {6, 13, {1, 1, 1, 15, 21, 21}},
    {6, 16, {1, 3, 1, 13, 27, 49}},
    {6, 19, {1, 1, 1, 15, 7, 5}},
    {6, 22, {1, 3, 1, 15, 13, 25}},
    {6, 25, {1, 1, 5, 5, 19, 61}},
    {7, 1, {1, 3, 7, 11, 23, 15, 103}},
    {7, 4, {1, 3, 7, 13, 13, 15, 69}},
    {7, 7, {1, 1, 3, 13, 7, 35, 63}},
    {7, 8, {1, 3, 5, 9, 1, 25, 53}},
    {7, 14, {1, 3, 1, 13, 9, 35, 107}},
    {7, 19, {1, 3, 1, 5, 27, 61, 31}},
    {7, 21, {1, 1, 5, 11, 19, 41, 61}},
    {7, 28, {1, 3, 5, 3, 3, 13, 69}},
    {7, 31, {1, 1, 7, 13, 1, 19, 1}},
    {7, 32, {1, 3, 7, 5, 13, 19, 59}},
    {7, 37, {1, 1, 3, 9, 25, 29, 41}},
}};

// The Sobol dimension of each walk coordinate: direction d is (kSobolOrder[2d],
// kSobolOrder[2d + 1]). Chosen greedily, direction by direction, among the dimensions
// left: the pair with the smallest worst t-value of its 2-D projection over the first
// 2^m points, m = 1..12 (0 for the first pair, 2 for the next eight, 3 for five more
// and 4 for the last), ties broken by the smallest sum of squared t-values with the
// dimensions already taken, so that a walk's directions stay spread against each other.
inline constexpr std::array<unsigned, 30> kSobolOrder = {0,  1,  2,  3,  4,  6,  5,  7,  9,  14, 11, 22, 16, 25, 8,
                                                         15, 19, 24, 12, 13, 10, 18, 21, 23, 17, 20, 26, 29, 27, 28};

// The 32 direction numbers v_k (as 32-bit fractions) of Sobol dimension `dim`
// (0: the van der Corput sequence).
inline std::array<std::uint32_t, 32> sobol_directions(unsigned dim) {
    std::array<std::uint32_t, 32> v{};
    if (dim == 0) {
        for (unsigned k = 0; k < 32; ++k) v[k] = 1u << (31 - k);
        return v;
    }
    const SobolPolynomial& p = kSobol[dim - 1];
    std::array<std::uint32_t, 32> m{};
    for (unsigned k = 0; k < p.s; ++k) m[k] = p.m[k];
    for (unsigned k = p.s; k < 32; ++k) {
        std::uint32_t x = m[k - p.s] ^ (m[k - p.s] << p.s);
        for (unsigned i = 1; i < p.s; ++i)
            if ((p.a >> (p.s - 1 - i)) & 1u) x ^= m[k - i] << i;
        m[k] = x;
    }
    for (unsigned k = 0; k < 32; ++k) v[k] = m[k] << (31 - k);
    return v;
}

// Radical inverse with the digits mapped through perm (perm.size() == base); the
// infinite tail of zero digits becomes perm[0] / (base - 1) at the last position.
inline double scrambled_radical_inverse(std::uint64_t i, unsigned base, const std::vector<unsigned>& perm) {
    const double inv = 1.0 / base;
    double f = inv, r = 0.0;
    // A fixed number of digits (enough for double precision), so that leading zeros
    // are permuted too.
    const int digits = static_cast<int>(std::ceil(53.0 * std::log(2.0) / std::log(static_cast<double>(base))));
    for (int k = 0; k < digits; ++k) {
        r += f * perm[i % base];
        i /= base;
        f *= inv;
    }
    return std::min(r, 1.0 - 0x1.0p-53);
}

}  // namespace detail

class WalkSampler {
public:
    static constexpr int kMaxSobolDepth = 15;  // 30 dimensions
    static constexpr int kMaxHaltonDepth = 32;

    WalkSampler(SamplerKind kind, int depth, std::uint64_t seed, std::uint64_t chain = 0)
        : kind_(kind), depth_(depth), seed_(seed), chain_(chain) {
        if (depth < 1) throw std::invalid_argument("walk depth must be >= 1, got " + std::to_string(depth));
        const int limit = kind == SamplerKind::sobol ? kMaxSobolDepth
                          : kind == SamplerKind::halton ? kMaxHaltonDepth : 1 << 20;
        if (depth > limit)
            throw std::invalid_argument(std::string("the ") + sampler_name(kind) + " sampler supports walks of depth " +
                                        "up to " + std::to_string(limit) + ", got " + std::to_string(depth));
        if (adaptive(kind))
            throw std::invalid_argument(std::string("the ") + sampler_name(kind) +
                                        " sampler adapts to the image: its walks come from solver/walk_source.h");
        const int dims = 2 * depth;
        Rng shift_rng(seed, streams::kWalkShifts[chain]);
        if (kind == SamplerKind::halton) {
            for (int k = 0; k < dims; ++k) {
                shift_.push_back(shift_rng.uniform());
                // A uniformly random permutation of the digits (Fisher-Yates).
                const unsigned b = detail::kPrimes[dimension(k)];
                bases_.push_back(b);
                std::vector<unsigned> perm(b);
                for (unsigned d = 0; d < b; ++d) perm[d] = d;
                for (unsigned d = b - 1; d > 0; --d) std::swap(perm[d], perm[shift_rng.next_u64() % (d + 1)]);
                perm_.push_back(std::move(perm));
            }
        } else if (kind == SamplerKind::sobol) {
            for (int k = 0; k < dims; ++k) {
                directions_.push_back(detail::sobol_directions(detail::kSobolOrder[dimension(k)]));
                mask_.push_back(static_cast<std::uint32_t>(shift_rng.next_u64() >> 32));
            }
        }
    }

    // Makes walk m the current one and computes its 2D coordinates.
    void start_walk(std::uint64_t m) {
        const int dims = 2 * depth_;
        point_.resize(static_cast<std::size_t>(dims));
        switch (kind_) {
            case SamplerKind::vegas:       // refused by the constructor
            case SamplerKind::metropolis:  // (no default: the compiler checks the cases)
            case SamplerKind::random: {
                Rng rng(seed_, streams::kWalks(chain_, m, 32));  // one stream per walk
                for (int k = 0; k < dims; ++k) point_[k] = rng.uniform();
                break;
            }
            case SamplerKind::halton:
                for (int k = 0; k < dims; ++k) {
                    double u = detail::scrambled_radical_inverse(m, bases_[k], perm_[k]) + shift_[k];
                    point_[k] = u >= 1.0 ? u - 1.0 : u;
                }
                break;
            case SamplerKind::sobol:
                for (int k = 0; k < dims; ++k) {
                    std::uint32_t x = mask_[k];
                    std::uint64_t i = m;
                    for (unsigned b = 0; i != 0 && b < 32; ++b, i >>= 1)
                        if (i & 1u) x ^= directions_[k][b];
                    point_[k] = static_cast<double>(x) * 0x1.0p-32;
                }
                break;
        }
    }

    // Coordinate k (0 <= k < 2 depth) of the current walk's point, in [0, 1).
    double coordinate(int k) const { return point_[static_cast<std::size_t>(k)]; }

    // The d-th direction (0 <= d < depth) of the current walk: unit, uniform on the sphere.
    Eigen::Vector3d direction(int d) const { return uniform_sphere(coordinate(2 * d), coordinate(2 * d + 1)); }

private:
    // The dimension of the sequence behind coordinate k: the walk's last direction takes
    // the first pair (the best stratified: Halton's smallest bases, Sobol's (0, 2)-net),
    // its first direction the last. The last direction decides what each patch receives
    // (every bounce arrives along it), the first only the highest bounce: on the
    // homogeneous box, plain walks of two chains of 500 walks were 8 % and combined
    // walks 16 % less wrong than in the sequence's order.
    std::size_t dimension(int k) const { return static_cast<std::size_t>(2 * (depth_ - 1 - k / 2) + k % 2); }

    SamplerKind kind_;
    int depth_;
    std::uint64_t seed_, chain_;
    std::vector<double> point_;
    std::vector<double> shift_;
    std::vector<unsigned> bases_;
    std::vector<std::vector<unsigned>> perm_;
    std::vector<std::array<std::uint32_t, 32>> directions_;
    std::vector<std::uint32_t> mask_;
};

}  // namespace raybundle::sampling
