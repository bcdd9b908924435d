#include "render/filters.h"

#include "scenes/threads.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

namespace raybundle::render {

namespace {

// ---------------------------------------------------------------- arguments

[[noreturn]] void fail(const char* fn, const std::string& what) {
    throw std::invalid_argument(std::string(fn) + ": " + what);
}

std::string str(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

std::string size_str(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

void check_images(const char* fn, const Image& input, const Guide& guide, int threads) {
    if (input.width < 0 || input.height < 0 ||
        input.rgb.size() != static_cast<std::size_t>(3) * input.width * input.height)
        fail(fn, "input " + size_str(input.width, input.height) + " holds " + std::to_string(input.rgb.size()) +
                     " floats, expected 3 per pixel");
    if (guide.width != input.width || guide.height != input.height)
        fail(fn, "guide size " + size_str(guide.width, guide.height) + " differs from input size " +
                     size_str(input.width, input.height));
    if (guide.data.size() != static_cast<std::size_t>(guide.channels) * guide.width * guide.height)
        fail(fn, "guide " + size_str(guide.width, guide.height) + " with " + std::to_string(guide.channels) +
                     " channels holds " + std::to_string(guide.data.size()) + " floats");
    if (threads < 1) fail(fn, "threads " + std::to_string(threads) + " < 1");
}

void check_channels(const char* fn, const Guide& guide, std::initializer_list<int> allowed, const char* list) {
    if (std::find(allowed.begin(), allowed.end(), guide.channels) == allowed.end())
        fail(fn, "guide channels " + std::to_string(guide.channels) + " not in " + list);
}

void check_sigma(const char* fn, const char* name, double v) {
    if (!(v > 0.0) || !std::isfinite(v)) fail(fn, std::string(name) + " " + str(v) + " is not a positive number");
}

// The smallest and largest value of every channel of an interleaved image.
struct Range {
    std::vector<double> lo, hi;
    double abs_max(int c) const { return std::max(-lo[c], hi[c]); }
};

// Per-channel minimum and maximum of an image with N interleaved channels, and whether
// every value is finite. Blocks of lcm(N, 4) floats go through four-lane vectors, so
// that every lane always sees the same channel.
template <int N>
void scan_range(const std::vector<float>& data, float* lo, float* hi, bool& finite) {
    using F4 = float __attribute__((vector_size(16)));
    using U4 = std::uint32_t __attribute__((vector_size(16)));
    constexpr int kBlock = N % 4 == 0 ? N : N % 2 == 0 ? 2 * N : 4 * N, kVecs = kBlock / 4;
    F4 l[kVecs], h[kVecs];
    U4 bad = {};
    for (int i = 0; i < kVecs; ++i) l[i] = h[i] = F4{} + data[0];  // data holds >= N values
    const std::size_t blocks = data.size() / kBlock;
    for (std::size_t b = 0; b < blocks; ++b)
        for (int i = 0; i < kVecs; ++i) {
            F4 v;
            std::memcpy(&v, &data[b * kBlock + 4 * i], sizeof v);
            U4 bits;
            std::memcpy(&bits, &v, sizeof bits);
            bad |= (bits & 0x7f800000u) == 0x7f800000u;  // exponent all ones: inf or nan
            l[i] = v < l[i] ? v : l[i];
            h[i] = v > h[i] ? v : h[i];
        }
    for (int c = 0; c < N; ++c) lo[c] = hi[c] = data[c];
    for (int i = 0; i < kVecs; ++i)
        for (int j = 0; j < 4; ++j) {
            const int c = (4 * i + j) % N;
            lo[c] = std::min(lo[c], l[i][j]);
            hi[c] = std::max(hi[c], h[i][j]);
        }
    bool ok = true;
    for (int j = 0; j < 4; ++j) ok &= bad[j] == 0;
    for (std::size_t k = blocks * kBlock; k < data.size(); ++k) {
        const float v = data[k];
        ok &= std::isfinite(v);
        lo[k % N] = std::min(lo[k % N], v);
        hi[k % N] = std::max(hi[k % N], v);
    }
    finite = ok;
}

// Throws on the first non-finite value; `what` names the image in the message.
Range channel_range(const char* fn, const char* what, const std::vector<float>& data, int channels, int width) {
    Range r{std::vector<double>(channels, 0.0), std::vector<double>(channels, 0.0)};
    if (data.empty()) return r;
    float lo[6], hi[6];
    bool finite = true;
    switch (channels) {  // channels are checked first: 1, 3, 4 or 6
    case 1: scan_range<1>(data, lo, hi, finite); break;
    case 3: scan_range<3>(data, lo, hi, finite); break;
    case 4: scan_range<4>(data, lo, hi, finite); break;
    default: scan_range<6>(data, lo, hi, finite); break;
    }
    if (!finite)
        for (std::size_t k = 0; k < data.size(); ++k)
            if (!std::isfinite(data[k])) {
                const std::size_t pixel = k / channels;
                fail(fn, std::string(what) + " value " + str(data[k]) + " at pixel (" + std::to_string(pixel % width) +
                             ", " + std::to_string(pixel / width) + ") channel " + std::to_string(k % channels));
            }
    std::copy(lo, lo + channels, r.lo.begin());
    std::copy(hi, hi + channels, r.hi.begin());
    return r;
}

// ---------------------------------------------------------------- threads

// Calls body(y0, y1) on `threads` contiguous row bands, one std::thread each.
template <class Body>
void parallel_rows(int rows, int threads, const Body& body) {
    const int n = std::max(1, std::min(threads, rows));
    if (n == 1) {
        body(0, rows);
        return;
    }
    run_threads(n, [&](int t) {
        body(static_cast<int>(static_cast<long long>(rows) * t / n),
             static_cast<int>(static_cast<long long>(rows) * (t + 1) / n));
    });
}

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
    parallel_rows(h, threads, [&](int y0, int y1) { GuidedBand<C>(s, out.rgb.data()).run(y0, y1); });
    return out;
}

// ---------------------------------------------------------------- bilateral and À-Trous

// Four floats at a time (one SSE2 operation); a float operand broadcasts.
using F4 = float __attribute__((vector_size(16)));
using I4 = std::int32_t __attribute__((vector_size(16)));
inline F4 load(const float* p) {
    F4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(float* p, F4 v) { std::memcpy(p, &v, sizeof v); }

// exp(x) for x <= 0: 2^n times a degree-6 Taylor polynomial of 2^f, |f| <= 1/2.
// Relative error below 7e-7 for x >= −8 and 4e-6 down to −87 (the float rounding of
// x·log2 e); below −87 it returns exp(−87) ≈ 1.6e-38, the smallest normal float.
inline F4 exp_negative(F4 x) {
    const F4 lo = F4{} - 87.0f;
    const F4 t = (x < lo ? lo : x) * 1.44269504f;
    const F4 n = (t + 12582912.0f) - 12582912.0f;  // 1.5·2^23: rounds to the nearest integer
    const F4 f = t - n;
    const F4 p = 1.0f + f * (0.693147181f +
                             f * (0.240226507f +
                                  f * (0.0555041087f + f * (0.00961812911f + f * (0.00133335581f + f * 0.000154035304f)))));
    const I4 bits = (__builtin_convertvector(n, I4) + 127) << 23;
    F4 scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

// Shared by the cross bilateral and À-Trous filters: planar copies of the guide and the
// colour, and the weighted sum of the taps at one offset for a whole row, four pixels
// at a time. Guide channels: [0, normals) the normal, [normals, channels) depth or
// position. Planes and rows carry 4 floats of padding for the last block's spare lanes.
struct EdgeFilter {
    int w, h, channels, normals;
    std::size_t pixels;
    std::vector<float> guide, colour, result;  // planar: channel c at [c * pixels]

    struct Row {  // the running sums of one output row
        std::size_t stride;
        std::vector<float> sum;  // 3 colour planes, then the weights
        explicit Row(int width) : stride(static_cast<std::size_t>(width) + 4), sum(4 * stride) {}
        void clear() { std::fill(sum.begin(), sum.end(), 0.0f); }
    };

    EdgeFilter(const Image& input, const Guide& g)
        : w(input.width), h(input.height), channels(g.channels), normals(g.channels >= 3 ? 3 : 0),
          pixels(static_cast<std::size_t>(w) * h), guide(pixels * channels + 4), colour(pixels * 3 + 4),
          result(pixels * 3 + 4) {
        for (std::size_t i = 0; i < pixels; ++i) {
            for (int c = 0; c < channels; ++c) guide[c * pixels + i] = g.data[i * channels + c];
            for (int c = 0; c < 3; ++c) colour[c * pixels + i] = input.rgb[i * 3 + c];
        }
    }

    // For every pixel x of row y whose tap (x+dx, y+dy) is inside the image, adds the tap
    // with weight  k · exp(e0 + kc·|Δcolour|² + kn·|Δnormal|² + kp·|Δdepth or position|²).
    void add_tap(Row& row, const float* col, int y, int dx, int dy, float e0, float k, float kc, float kn,
                 float kp) const {
        const int qy = y + dy;
        if (qy < 0 || qy >= h) return;
        const int x0 = std::max(0, -dx), x1 = std::min(w, w - dx);
        if (x0 >= x1) return;
        const bool c = kc != 0.0f;  // the bilateral filter has no colour term
        switch (channels) {
        case 1: c ? tap<0, 1, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<0, 1, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        case 3: c ? tap<3, 0, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<3, 0, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        case 4: c ? tap<3, 1, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                  : tap<3, 1, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        default: c ? tap<3, 3, true>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp)
                   : tap<3, 3, false>(row, col, y, qy, dx, x0, x1, e0, k, kc, kn, kp); break;
        }
    }

    template <int Normals, int Positions, bool ColourTerm>
    void tap(Row& row, const float* col, int y, int qy, int dx, int x0, int x1, float e0, float k, float kc, float kn,
             float kp) const {
        const float* gp = guide.data() + static_cast<std::size_t>(y) * w;
        const float* gq = guide.data() + static_cast<std::size_t>(qy) * w + dx;
        const float* cp = col + static_cast<std::size_t>(y) * w;
        const float* cq = col + static_cast<std::size_t>(qy) * w + dx;
        float* s = row.sum.data();
        const std::size_t rs = row.stride;
        const I4 lane = {0, 1, 2, 3};
        for (int x = x0; x < x1; x += 4) {
            F4 dn = {}, dp = {}, dc = {};
            for (int c = 0; c < Normals; ++c) {
                const F4 d = load(gp + c * pixels + x) - load(gq + c * pixels + x);
                dn += d * d;
            }
            for (int c = Normals; c < Normals + Positions; ++c) {
                const F4 d = load(gp + c * pixels + x) - load(gq + c * pixels + x);
                dp += d * d;
            }
            if (ColourTerm)
                for (int c = 0; c < 3; ++c) {
                    const F4 d = load(cp + c * pixels + x) - load(cq + c * pixels + x);
                    dc += d * d;
                }
            F4 wt = k * exp_negative(e0 + kc * dc + kn * dn + kp * dp);
            wt = lane + x < x1 ? wt : F4{};  // the last block's lanes past x1 add nothing
            for (int c = 0; c < 3; ++c) store(s + c * rs + x, load(s + c * rs + x) + wt * load(cq + c * pixels + x));
            store(s + 3 * rs + x, load(s + 3 * rs + x) + wt);
        }
    }

    // out[·][y] = weighted sum / sum of weights (> 0: the centre tap is always there).
    void store_row(const Row& row, int y, float* out) const {
        const std::size_t p = static_cast<std::size_t>(y) * w;
        for (int c = 0; c < 3; ++c)
            for (int x = 0; x < w; ++x)
                out[c * pixels + p + x] = row.sum[c * row.stride + x] / row.sum[3 * row.stride + x];
    }

    Image interleaved(const std::vector<float>& planes) const {
        Image img(w, h);
        for (std::size_t i = 0; i < pixels; ++i)
            for (int c = 0; c < 3; ++c) img.rgb[i * 3 + c] = planes[c * pixels + i];
        return img;
    }
};

}  // namespace

// ---------------------------------------------------------------- public

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

Image cross_bilateral_filter(const Image& input, const Guide& guide, int radius, double sigma_spatial,
                             double sigma_normal, double sigma_depth, int threads) {
    const char* fn = "cross_bilateral_filter";
    check_images(fn, input, guide, threads);
    check_channels(fn, guide, {1, 3, 4}, "{1, 3, 4}");
    if (radius < 1) fail(fn, "radius " + std::to_string(radius) + " < 1");
    check_sigma(fn, "sigma_spatial", sigma_spatial);
    check_sigma(fn, "sigma_normal", sigma_normal);
    check_sigma(fn, "sigma_depth", sigma_depth);
    channel_range(fn, "guide", guide.data, guide.channels, guide.width);
    channel_range(fn, "input", input.rgb, 3, input.width);

    EdgeFilter f(input, guide);
    const float kn = static_cast<float>(-0.5 / (sigma_normal * sigma_normal));
    const float kz = static_cast<float>(-0.5 / (sigma_depth * sigma_depth));
    const float ks = static_cast<float>(-0.5 / (sigma_spatial * sigma_spatial));
    parallel_rows(f.h, threads, [&](int y0, int y1) {
        EdgeFilter::Row row(f.w);
        for (int y = y0; y < y1; ++y) {
            row.clear();
            for (int dy = -radius; dy <= radius; ++dy)
                for (int dx = -radius; dx <= radius; ++dx)
                    f.add_tap(row, f.colour.data(), y, dx, dy, static_cast<float>(dx * dx + dy * dy) * ks, 1.0f, 0.0f,
                              kn, kz);
            f.store_row(row, y, f.result.data());
        }
    });
    return f.interleaved(f.result);
}

Image atrous_filter(const Image& input, const Guide& guide, int iterations, double sigma_colour,
                    double sigma_normal, double sigma_position, int threads) {
    const char* fn = "atrous_filter";
    check_images(fn, input, guide, threads);
    check_channels(fn, guide, {1, 3, 4, 6}, "{1, 3, 4, 6}");
    if (iterations < 1 || iterations > 16) fail(fn, "iterations " + std::to_string(iterations) + " not in [1, 16]");
    check_sigma(fn, "sigma_colour", sigma_colour);
    check_sigma(fn, "sigma_normal", sigma_normal);
    check_sigma(fn, "sigma_position", sigma_position);
    channel_range(fn, "guide", guide.data, guide.channels, guide.width);
    channel_range(fn, "input", input.rgb, 3, input.width);

    EdgeFilter f(input, guide);
    static constexpr float kB3[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    const float kn = static_cast<float>(-1.0 / (sigma_normal * sigma_normal));
    const float kx = static_cast<float>(-1.0 / (sigma_position * sigma_position));
    for (int it = 0; it < iterations; ++it) {
        const int step = 1 << it;
        const double sc = sigma_colour / step;
        const float kc = static_cast<float>(-1.0 / (sc * sc));
        parallel_rows(f.h, threads, [&](int y0, int y1) {
            EdgeFilter::Row row(f.w);
            for (int y = y0; y < y1; ++y) {
                row.clear();
                for (int j = 0; j < 5; ++j)
                    for (int i = 0; i < 5; ++i)
                        f.add_tap(row, f.colour.data(), y, (i - 2) * step, (j - 2) * step, 0.0f, kB3[j] * kB3[i], kc,
                                  kn, kx);
                f.store_row(row, y, f.result.data());
            }
        });
        std::swap(f.colour, f.result);
    }
    return f.interleaved(f.colour);
}

}  // namespace raybundle::render
