// He, Sun and Tang's guided image filter (render/filters.h) with exact running sums.
#include "render/filter_support.h"
#include "render/filters.h"
#include "scenes/threads.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace raybundle::render {

using namespace detail;

namespace {

// ---------------------------------------------------------------- exact box sums

// OpenCV's BORDER_REFLECT: fedcba|abcdefgh|hgfedcb, repeated while out of range.
int reflect(int p, int n) {
    if (n == 1) return 0;
    while (p < 0 || p >= n) p = p < 0 ? -p - 1 : 2 * n - p - 1;
    return p;
}

// Reflected indices of the positions -r-1 .. n+r; index with table.data() + r + 1.
std::vector<int> reflect_table(int n, int r) {
    std::vector<int> t(static_cast<std::size_t>(n) + 2 * r + 2);
    for (int p = -r - 1; p <= n + r; ++p) t[p + r + 1] = reflect(p, n);
    return t;
}

// (v·s + 1.5·2^52) − 1.5·2^52 rounds v·s to the nearest integer when |v·s| < 2^51.
constexpr double kRound = 6755399441055744.0;
inline double quantise(double v, double s) { return (v * s + kRound) - kRound; }

// The power of two s such that |round(v·s)| summed over `2^area_log2` values of
// |v| <= vmax stays below 2^51: all such sums are exact in double.
double quantum_scale(double vmax, int area_log2) {
    if (!(vmax > 0.0)) return 1.0;
    return std::ldexp(1.0, 51 - area_log2 - (std::ilogb(vmax) + 1));
}

int ceil_log2(long long v) {
    int l = 0;
    while ((1LL << l) < v) ++l;
    return l;
}

// Planes of a channel-major row lie `plane_stride(w)` doubles apart: a little more than
// w, so that the planes of one pixel do not all fall into the same cache set.
std::size_t plane_stride(int w) { return (static_cast<std::size_t>(w) + 7) / 8 * 8 + 8; }

// Horizontal (2r+1)-wide window sums of G channel-major rows of length w, n apart:
// out[g][x] = Σ_j col[g][cols[x+j]]. G running sums advance side by side.
template <int G>
void box_rows_group(const double* col, double* out, int w, std::size_t n, int r, const int* cols) {
    double acc[G] = {};
    for (int j = -r; j <= r; ++j)
        for (int g = 0; g < G; ++g) acc[g] += col[g * n + cols[j]];
    for (int x = 0; x < w; ++x) {
        const int xin = cols[x + r + 1], xout = cols[x - r];
        for (int g = 0; g < G; ++g) {
            const double* c = col + g * n;
            out[g * n + x] = acc[g];
            acc[g] += c[xin] - c[xout];
        }
    }
}

template <int K>
void box_rows(const double* col, double* out, int w, std::size_t n, int r, const int* cols) {
    int k = 0;
    for (; k + 4 <= K; k += 4) box_rows_group<4>(col + k * n, out + k * n, w, n, r, cols);
    for (; k < K; ++k) box_rows_group<1>(col + k * n, out + k * n, w, n, r, cols);
}

// ---------------------------------------------------------------- guided filter

// Pass 1 sums K1 products of the C + 3 planes of a row (the guide's channels, then the
// input's): Ī (C), the upper triangle of I Iᵀ, p̄ (3) and I p per colour (3C). Pass 2
// sums K2 coefficients: a (C per colour), then b (3).
template <int C>
struct Layout {
    static constexpr int kPairs = C * (C + 1) / 2;
    static constexpr int kGuide = 0, kGuideGuide = C, kInput = C + kPairs, kGuideInput = C + kPairs + 3;
    static constexpr int K1 = C + kPairs + 3 + 3 * C;
    static constexpr int K2 = 3 * C + 3;
    // Feature k is plane u[k] times plane v[k] (v[k] < 0: plane u[k] alone).
    struct Products {
        int u[K1], v[K1];
    };
    static constexpr Products products() {
        Products p{};
        int k = 0;
        for (int i = 0; i < C; ++i) p.u[k] = i, p.v[k++] = -1;
        for (int i = 0; i < C; ++i)
            for (int j = i; j < C; ++j) p.u[k] = i, p.v[k++] = j;
        for (int c = 0; c < 3; ++c) p.u[k] = C + c, p.v[k++] = -1;
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < C; ++i) p.u[k] = i, p.v[k++] = C + c;
        return p;
    }
};

// Two pixels at a time: a GCC vector extension, one SSE2 register on baseline x86-64
// (four-lane vectors measured slower there). Arithmetic with a double broadcasts it.
using Vec = double __attribute__((vector_size(16)));
constexpr int kLanes = 2;
inline Vec load(const double* p) {
    Vec v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(double* p, Vec v) { std::memcpy(p, &v, sizeof v); }
inline Vec quantise(Vec v, double s) { return (v * s + kRound) - kRound; }

inline Vec clamp(Vec v, double bound) {
    const Vec hi = Vec{} + bound, lo = -hi;
    v = v < lo ? lo : v;
    return v > hi ? hi : v;
}

// a = (Σ + diag ε)⁻¹ cov for the three colours; S holds the upper triangle of Σ + diag ε.
template <int C, class T>
struct Solve;

template <class T>
struct Solve<1, T> {
    static void run(const T* S, const T (*cov)[1], T (*a)[1]) {
        const T inv = 1.0 / S[0];
        for (int c = 0; c < 3; ++c) a[c][0] = cov[c][0] * inv;
    }
};

template <class T>
struct Solve<3, T> {
    static void run(const T* S, const T (*cov)[3], T (*a)[3]) {
        // Closed-form inverse: cofactors over the determinant.
        const T s00 = S[0], s01 = S[1], s02 = S[2], s11 = S[3], s12 = S[4], s22 = S[5];
        const T c00 = s11 * s22 - s12 * s12, c01 = s02 * s12 - s01 * s22, c02 = s01 * s12 - s02 * s11;
        const T c11 = s00 * s22 - s02 * s02, c12 = s01 * s02 - s00 * s12, c22 = s00 * s11 - s01 * s01;
        const T inv = 1.0 / (s00 * c00 + s01 * c01 + s02 * c02);
        for (int c = 0; c < 3; ++c) {
            const T* v = cov[c];
            a[c][0] = (c00 * v[0] + c01 * v[1] + c02 * v[2]) * inv;
            a[c][1] = (c01 * v[0] + c11 * v[1] + c12 * v[2]) * inv;
            a[c][2] = (c02 * v[0] + c12 * v[1] + c22 * v[2]) * inv;
        }
    }
};

template <class T>
struct Solve<4, T> {
    static void run(const T* S, const T (*cov)[4], T (*a)[4]) {
        // LDLᵀ of the symmetric positive definite 4×4 matrix (ε > 0), written out so
        // that everything stays in registers, then three forward and back substitutions.
        const T s00 = S[0], s01 = S[1], s02 = S[2], s03 = S[3], s11 = S[4], s12 = S[5], s13 = S[6];
        const T s22 = S[7], s23 = S[8], s33 = S[9];
        const T i0 = 1.0 / s00;
        const T l10 = s01 * i0, l20 = s02 * i0, l30 = s03 * i0;
        const T d1 = s11 - l10 * s01, i1 = 1.0 / d1;
        const T l21 = (s12 - l20 * s01) * i1, l31 = (s13 - l30 * s01) * i1;
        const T d2 = s22 - l20 * s02 - l21 * l21 * d1, i2 = 1.0 / d2;
        const T l32 = (s23 - l30 * s02 - l31 * l21 * d1) * i2;
        const T d3 = s33 - l30 * s03 - l31 * l31 * d1 - l32 * l32 * d2, i3 = 1.0 / d3;
        for (int c = 0; c < 3; ++c) {
            const T y0 = cov[c][0], y1 = cov[c][1] - l10 * y0, y2 = cov[c][2] - l20 * y0 - l21 * y1;
            const T y3 = cov[c][3] - l30 * y0 - l31 * y1 - l32 * y2;
            const T a3 = y3 * i3, a2 = y2 * i2 - l32 * a3, a1 = y1 * i1 - l21 * a2 - l31 * a3;
            a[c][0] = y0 * i0 - l10 * a1 - l20 * a2 - l30 * a3;
            a[c][1] = a1;
            a[c][2] = a2;
            a[c][3] = a3;
        }
    }
};

// Everything a band of rows needs to know about the filter, fixed before any band
// starts (so every band computes identical values for the rows it shares).
template <int C>
struct GuidedSetup {
    using L = Layout<C>;
    int w, h, r;
    const float* guide;
    const float* input;
    const int* rows;  // reflect tables, valid for -r-1 .. n+r
    const int* cols;
    double eps[C];
    double centre[C + 3];                // mid-range of every guide and input channel
    double scale1[L::K1], mean1[L::K1];  // pass 1: quantum scale, and sum -> mean factor
    double scale2[L::K2], mean2[L::K2];  // pass 2
    double bound2[L::K2];                // |a|, |b| never exceed these
};

// One band of output rows [y0, y1). Pass 1 produces the quantised coefficient rows
// [max(0, y0−r), min(h−1, y1−1+r)] in order into a ring of 2r+2 rows (the whole image
// when that is smaller), and pass 2 consumes them, 2r+1 rows behind.
template <int C>
class GuidedBand {
public:
    using L = Layout<C>;
    static constexpr int K1 = L::K1, K2 = L::K2, P = C + 3;

    GuidedBand(const GuidedSetup<C>& s, float* out)
        : s_(s), out_(out), cap_(std::min(s.h, 2 * s.r + 2)), w_(static_cast<std::size_t>(s.w)), n_(plane_stride(s.w)),
          col1_(K1 * n_), col2_(K2 * n_), sums_(K1 * n_), in_(P * n_), old_(P * n_),
          ring_(static_cast<std::size_t>(cap_) * K2 * n_) {}

    void run(int y0, int y1) {
        const int r = s_.r;
        first_ = next_ = std::max(0, y0 - r);
        for (int j = -r; j <= r; ++j) {  // pass-1 column sums for row first_
            planes(s_.rows[next_ + j], in_.data());
            add_features(in_.data(), nullptr);
        }
        for (int y = y0; y < y1; ++y) {
            produce_until(std::min(s_.h - 1, y + r));
            if (y == y0) {
                for (int j = -r; j <= r; ++j) add_ring(s_.rows[y + j], -1);
            } else if (s_.rows[y + r] != s_.rows[y - r - 1]) {
                add_ring(s_.rows[y + r], s_.rows[y - r - 1]);
            }
            box_rows<K2>(col2_.data(), sums_.data(), s_.w, n_, r, s_.cols);
            output_row(y);
        }
    }

private:
    // The C + 3 planes of row y, as doubles: guide channels, then input channels, each
    // minus its channel's mid-range.
    void planes(int y, double* e) const {
        const float* g = s_.guide + static_cast<std::size_t>(y) * w_ * C;
        const float* p = s_.input + static_cast<std::size_t>(y) * w_ * 3;
        for (std::size_t x = 0; x < w_; ++x) {
            for (int c = 0; c < C; ++c) e[c * n_ + x] = g[x * C + c] - s_.centre[c];
            for (int c = 0; c < 3; ++c) e[(C + c) * n_ + x] = p[x * 3 + c] - s_.centre[C + c];
        }
    }

    // col1 += quantised features of `add` − those of `sub` (sub may be null).
    void add_features(const double* add, const double* sub) {
        static constexpr typename L::Products f = L::products();
        for (int k = 0; k < K1; ++k) {
            double* __restrict c = &col1_[k * n_];
            const double s = s_.scale1[k];
            const double* a = add + f.u[k] * n_;
            const double* b = sub ? sub + f.u[k] * n_ : nullptr;
            if (f.v[k] < 0) {
                if (b)
                    for (std::size_t x = 0; x < w_; ++x) c[x] += quantise(a[x], s) - quantise(b[x], s);
                else
                    for (std::size_t x = 0; x < w_; ++x) c[x] += quantise(a[x], s);
            } else {
                const double* a2 = add + f.v[k] * n_;
                if (b) {
                    const double* b2 = sub + f.v[k] * n_;
                    for (std::size_t x = 0; x < w_; ++x)
                        c[x] += quantise(a[x] * a2[x], s) - quantise(b[x] * b2[x], s);
                } else {
                    for (std::size_t x = 0; x < w_; ++x) c[x] += quantise(a[x] * a2[x], s);
                }
            }
        }
    }

    // Pass 1 up to and including row `last`: window sums, then a and b per pixel.
    void produce_until(int last) {
        const int r = s_.r;
        for (; next_ <= last; ++next_) {
            const int yin = s_.rows[next_ + r], yout = s_.rows[next_ - r - 1];
            if (next_ > first_ && yin != yout) {  // slide the window down one row
                planes(yin, in_.data());
                planes(yout, old_.data());
                add_features(in_.data(), old_.data());
            }
            box_rows<K1>(col1_.data(), sums_.data(), s_.w, n_, r, s_.cols);
            coefficients(&ring_[static_cast<std::size_t>(next_ % cap_) * K2 * n_]);
        }
    }

    // a and b from the window sums in sums_, clamped to their bounds, quantised; two
    // pixels at a time (the planes' padding takes the last block's spare lane).
    void coefficients(double* ab) const {
        const double* sums = sums_.data();
        for (std::size_t x = 0; x < w_; x += kLanes) {
            Vec m[K1];
            for (int k = 0; k < K1; ++k) m[k] = load(&sums[k * n_ + x]) * s_.mean1[k];
            const Vec* mu = m + L::kGuide;
            Vec S[L::kPairs];
            for (int i = 0, k = 0; i < C; ++i)
                for (int j = i; j < C; ++j, ++k) {
                    S[k] = m[L::kGuideGuide + k] - mu[i] * mu[j];
                    if (i == j) S[k] += s_.eps[i];
                }
            Vec cov[3][C], a[3][C];
            for (int c = 0; c < 3; ++c)
                for (int i = 0; i < C; ++i) cov[c][i] = m[L::kGuideInput + c * C + i] - mu[i] * m[L::kInput + c];
            Solve<C, Vec>::run(S, cov, a);
            for (int c = 0; c < 3; ++c) {
                Vec b = m[L::kInput + c];
                for (int i = 0; i < C; ++i) {
                    const int k = c * C + i;
                    const Vec v = clamp(a[c][i], s_.bound2[k]);
                    store(&ab[k * n_ + x], quantise(v, s_.scale2[k]));
                    b -= v * mu[i];
                }
                const int k = 3 * C + c;
                store(&ab[k * n_ + x], quantise(clamp(b, s_.bound2[k]), s_.scale2[k]));
            }
        }
    }

    // col2 += ring row `add` − ring row `sub` (sub < 0: none).
    void add_ring(int add, int sub) {
        const double* a = &ring_[static_cast<std::size_t>(add % cap_) * K2 * n_];
        double* __restrict c = col2_.data();
        if (sub < 0) {
            for (std::size_t i = 0; i < K2 * n_; ++i) c[i] += a[i];
        } else {
            const double* b = &ring_[static_cast<std::size_t>(sub % cap_) * K2 * n_];
            for (std::size_t i = 0; i < K2 * n_; ++i) c[i] += a[i] - b[i];
        }
    }

    // q = āᵀ I + b̄ (+ the input's centre) for every pixel of row y, two at a time.
    void output_row(int y) {
        planes(y, in_.data());
        const double* sums = sums_.data();
        const double* g = in_.data();
        float* o = out_ + static_cast<std::size_t>(y) * w_ * 3;
        for (std::size_t x = 0; x < w_; x += kLanes) {
            const std::size_t lanes = std::min<std::size_t>(kLanes, w_ - x);
            for (int c = 0; c < 3; ++c) {
                Vec q = load(&sums[(3 * C + c) * n_ + x]) * s_.mean2[3 * C + c] + s_.centre[C + c];
                for (int i = 0; i < C; ++i)
                    q += load(&sums[(c * C + i) * n_ + x]) * s_.mean2[c * C + i] * load(&g[i * n_ + x]);
                for (std::size_t l = 0; l < lanes; ++l) o[(x + l) * 3 + c] = static_cast<float>(q[l]);
            }
        }
    }

    const GuidedSetup<C>& s_;
    float* out_;
    int cap_;
    std::size_t w_, n_;  // row length; stride between the planes of a channel-major row
    std::vector<double> col1_, col2_, sums_, in_, old_;
    std::vector<double> ring_;  // quantised a and b of the last cap_ rows
    int first_ = 0, next_ = 0;  // pass 1 started at row first_; next_ is the next to produce
};

template <int C>
Image guided_filter_c(const Image& input, const Guide& guide, int r, const std::vector<double>& eps, int threads) {
    using L = Layout<C>;
    const int w = input.width, h = input.height;
    const long long area = (2LL * r + 1) * (2LL * r + 1);
    const int area_log2 = ceil_log2(area);
    const std::vector<int> rows = reflect_table(h, r), cols = reflect_table(w, r);

    GuidedSetup<C> s;
    s.w = w, s.h = h, s.r = r;
    s.guide = guide.data.data();
    s.input = input.rgb.data();
    s.rows = rows.data() + r + 1;
    s.cols = cols.data() + r + 1;
    for (int i = 0; i < C; ++i) s.eps[i] = eps.size() == 1 ? eps[0] : eps[i];

    // The filter is equivariant to shifts of the guide (b absorbs them) and of the input,
    // so both are centred on their channels' mid-range: that keeps the summed values,
    // and so the quanta, small, and E[I²] − E[I]² free of a large offset.
    const Range grange = channel_range("guided_filter", "guide", guide.data, C, w);
    const Range prange = channel_range("guided_filter", "input", input.rgb, 3, w);
    double half[C + 3];  // half ranges: every centred value lies within ±half
    for (int i = 0; i < C + 3; ++i) {
        const Range& range = i < C ? grange : prange;
        const int c = i < C ? i : i - C;
        s.centre[i] = 0.5 * (range.lo[c] + range.hi[c]);
        half[i] = 0.5 * (range.hi[c] - range.lo[c]);
    }
    static constexpr typename L::Products f = L::products();
    for (int k = 0; k < L::K1; ++k) {
        const double m = half[f.u[k]] * (f.v[k] < 0 ? 1.0 : half[f.v[k]]);
        s.scale1[k] = quantum_scale(m, area_log2);
        s.mean1[k] = 1.0 / s.scale1[k] / static_cast<double>(area);
    }
    // a minimises mean((aᵀ(I−Ī) − (p−p̄))²) + Σ ε_i a_i², which is var(p) at a = 0, so
    // Σ ε_i a_i² <= var(p) <= R² with R the input channel's half range: |a_i| <= R/√ε_i;
    // and for the centred b = p̄ − aᵀĪ, |b| <= R + R·(Σ half_i²/ε_i)^½ (Cauchy-Schwarz).
    // Coefficients are clamped to these bounds (a no-op unless rounding broke them).
    double spread = 0.0;
    for (int i = 0; i < C; ++i) spread += half[i] * half[i] / s.eps[i];
    for (int c = 0; c < 3; ++c) {
        const double R = half[C + c];
        for (int i = 0; i < C; ++i) s.bound2[c * C + i] = R / std::sqrt(s.eps[i]);
        s.bound2[3 * C + c] = R * (1.0 + std::sqrt(spread));
    }
    for (int k = 0; k < L::K2; ++k) {
        s.scale2[k] = quantum_scale(s.bound2[k], area_log2);
        s.mean2[k] = 1.0 / s.scale2[k] / static_cast<double>(area);
    }

    Image out(w, h);
    parallel_bands(h, threads, [&](int y0, int y1) { GuidedBand<C>(s, out.rgb.data()).run(y0, y1); });
    return out;
}

}  // namespace

Image guided_filter(const Image& input, const Guide& guide, int radius, double eps, int threads) {
    return guided_filter(input, guide, radius, std::vector<double>{eps}, threads);
}

Image guided_filter(const Image& input, const Guide& guide, int radius, const std::vector<double>& eps,
                    int threads) {
    const char* fn = "guided_filter";
    check_images(fn, input, guide, threads);
    check_channels(fn, guide, {1, 3, 4}, "{1, 3, 4}");
    if (radius < 1) fail(fn, "radius " + std::to_string(radius) + " < 1");
    // The quanta of the exact sums grow with the window: 2^-27 of a channel's bound here.
    if (radius > kMaxGuidedRadius)
        fail(fn, "radius " + std::to_string(radius) + " > " + std::to_string(kMaxGuidedRadius));
    if (eps.size() != 1 && eps.size() != static_cast<std::size_t>(guide.channels))
        fail(fn, "eps has " + std::to_string(eps.size()) + " values, expected 1 or " +
                     std::to_string(guide.channels) + " (one per guide channel)");
    for (double e : eps) {
        if (!(e > 0.0)) fail(fn, "eps " + str(e) + " <= 0");
        if (!std::isfinite(e)) fail(fn, "eps " + str(e) + " is not finite");
    }
    if (input.width == 0 || input.height == 0) return Image(input.width, input.height);
    switch (guide.channels) {
    case 1: return guided_filter_c<1>(input, guide, radius, eps, threads);
    case 3: return guided_filter_c<3>(input, guide, radius, eps, threads);
    default: return guided_filter_c<4>(input, guide, radius, eps, threads);
    }
}

}  // namespace raybundle::render
