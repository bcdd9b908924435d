#include "visibility/exact_spans.h"

#include "visibility/raster.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define RAYBUNDLE_AVX2_KERNELS 1
#include <immintrin.h>
#endif

namespace raybundle::visibility {

namespace {

// The key at column x of a row whose value at column 0 is `row` (= row0 + dy y).
inline std::int32_t key_at(double row, const DepthPlane& p, int x) {
    double v = row + p.dx * static_cast<double>(x);
    v = v < p.lo ? p.lo : v;
    v = v > p.hi ? p.hi : v;
    return static_cast<std::int32_t>(v);
}

inline double row_value(const DepthPlane& p, int y) { return p.row0 + p.dy * static_cast<double>(y); }

struct Corners {
    double v[3];
};
inline Corners corners(const std::int32_t* c) { return {{double(c[0]), double(c[1]), double(c[2])}}; }

inline void count_seen(SourceCounts& s, std::uint32_t a) {
    if (a != s.current) {
        flush_run(s);
        s.current = a;
    }
    ++s.run;
}

// The portable kernels: pixel by pixel; in_order(a) for each pixel drawn in order,
// with `a` the occupant it replaced.
template <class InOrder>
void draw_portable(const Band& b, const Triangle& t, std::vector<SlowPixel>& slow, InOrder&& in_order) {
    rasterize_triangle(corners(t.X).v, corners(t.Y).v, 0, b.W, b.y_first, b.y_end, [&](int y, int x0, int x1) {
        const std::size_t row = static_cast<std::size_t>(y - b.y_first) * b.W;
        std::uint32_t* const A = b.A + row;
        std::int32_t* const K = b.K + row;
        std::uint32_t* const B = b.B + row;
        const double r = row_value(t.plane, y);
        for (int x = x0; x < x1; ++x) {
            const std::int32_t key = key_at(r, t.plane, x);
            if (key > K[x] + kDepthTie) {
                const std::uint32_t a = K[x] == 0 ? b.initial : A[x];
                B[x] = a;
                A[x] = t.id;
                K[x] = key;
                in_order(a);
            } else {
                slow.push_back({static_cast<std::uint32_t>(row + x), x, y, static_cast<std::uint32_t>(key)});
            }
        }
    });
}

void source_portable(const Band& b, const Triangle& t, std::vector<SlowPixel>& slow) {
    draw_portable(b, t, slow, [](std::uint32_t) {});
}

void receiver_portable(const Band& b, const Triangle& t, SourceCounts& counts, std::vector<SlowPixel>& slow) {
    SourceCounts seen = counts;  // a local copy: the map's stores cannot alias it
    draw_portable(b, t, slow, [&](std::uint32_t a) { count_seen(seen, a); });
    counts = seen;
}

#ifdef RAYBUNDLE_AVX2_KERNELS
#define RB_AVX2 __attribute__((target("avx2")))

// The mask of the first n lanes: loadu(kLanes + 8 - n).
alignas(32) const std::int32_t kLanes[16] = {-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0};

// One step of 8 pixels of a row: the lanes [0, n) in order get B = A, A = id,
// K = key. Returns the mask of the lanes in order; `a` the old occupants, `keys` the keys.
struct Step8 {
    __m256d dx, lo, hi;
    __m256i id, tie, initial;
    RB_AVX2 Step8(const Triangle& t, const Band& b)
        : dx(_mm256_set1_pd(t.plane.dx)),
          lo(_mm256_set1_pd(t.plane.lo)),
          hi(_mm256_set1_pd(t.plane.hi)),
          id(_mm256_set1_epi32(static_cast<int>(t.id))),
          tie(_mm256_set1_epi32(kDepthTie)),
          initial(_mm256_set1_epi32(static_cast<int>(b.initial))) {}

    // key_at() for columns x..x+7: the same operations, lane by lane.
    RB_AVX2 __m256i keys(__m256d row, int x) const {
        const __m256d base = _mm256_set1_pd(static_cast<double>(x));
        const __m256d c0 = _mm256_add_pd(base, _mm256_setr_pd(0, 1, 2, 3));
        const __m256d c1 = _mm256_add_pd(base, _mm256_setr_pd(4, 5, 6, 7));
        const __m256d v0 = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(row, _mm256_mul_pd(dx, c0)), lo), hi);
        const __m256d v1 = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(row, _mm256_mul_pd(dx, c1)), lo), hi);
        return _mm256_set_m128i(_mm256_cvttpd_epi32(v1), _mm256_cvttpd_epi32(v0));
    }

    RB_AVX2 int draw(std::uint32_t* A, std::int32_t* K, std::uint32_t* B, __m256d row, int x, int n, __m256i& a,
                     __m256i& k8) const {
        const __m256i span = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(kLanes + 8 - n));
        k8 = keys(row, x);
        auto* const pk = reinterpret_cast<__m256i*>(K + x);
        auto* const pa = reinterpret_cast<__m256i*>(A + x);
        auto* const pb = reinterpret_cast<__m256i*>(B + x);
        // All loads before the stores (which the compiler must assume alias them).
        const __m256i k = _mm256_loadu_si256(pk);
        const __m256i a_raw = _mm256_loadu_si256(pa);
        const __m256i b_old = _mm256_loadu_si256(pb);
        // Key 0: the pixel still holds the initial occupant.
        a = _mm256_blendv_epi8(a_raw, initial, _mm256_cmpeq_epi32(k, _mm256_setzero_si256()));
        const __m256i in = _mm256_and_si256(span, _mm256_cmpgt_epi32(k8, _mm256_add_epi32(k, tie)));
        const int mask = _mm256_movemask_ps(_mm256_castsi256_ps(in));
        // Lanes outside `in` are written back unchanged (no branch: spans vary in length).
        _mm256_storeu_si256(pb, _mm256_blendv_epi8(b_old, a, in));
        _mm256_storeu_si256(pa, _mm256_blendv_epi8(a_raw, id, in));
        _mm256_storeu_si256(pk, _mm256_blendv_epi8(k, k8, in));
        return mask;
    }
};

// The lanes of a step inside the span but not in order go to the slow path.
RB_AVX2 void hand_back(int mask, int n, std::size_t row, int x, int y, __m256i k8, std::vector<SlowPixel>& slow) {
    const int out = ~mask & ((1 << n) - 1);
    if (out == 0) return;
    alignas(32) std::uint32_t k[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(k), k8);
    for (int l = 0; l < n; ++l)
        if ((out >> l) & 1) slow.push_back({static_cast<std::uint32_t>(row + x + l), x + l, y, k[l]});
}

RB_AVX2 void source_avx2(const Band& b, const Triangle& t, std::vector<SlowPixel>& slow) {
    const Step8 s(t, b);
    rasterize_triangle(corners(t.X).v, corners(t.Y).v, 0, b.W, b.y_first, b.y_end, [&](int y, int x0, int x1) RB_AVX2 {
        const std::size_t row = static_cast<std::size_t>(y - b.y_first) * b.W;
        const __m256d r = _mm256_set1_pd(row_value(t.plane, y));
        for (int x = x0; x < x1; x += 8) {
            const int n = x1 - x < 8 ? x1 - x : 8;
            __m256i a, k8;
            const int mask = s.draw(b.A + row, b.K + row, b.B + row, r, x, n, a, k8);
            if (mask != (1 << n) - 1) hand_back(mask, n, row, x, y, k8, slow);
        }
    });
}

RB_AVX2 void receiver_avx2(const Band& b, const Triangle& t, SourceCounts& counts, std::vector<SlowPixel>& slow) {
    const Step8 s(t, b);
    SourceCounts seen = counts;  // a local copy: the map's stores cannot alias it
    // Lane l's predecessor: lane l - 1 (lane 0's is the current run).
    const __m256i previous_lane = _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6);
    rasterize_triangle(corners(t.X).v, corners(t.Y).v, 0, b.W, b.y_first, b.y_end, [&](int y, int x0, int x1) RB_AVX2 {
        const std::size_t row = static_cast<std::size_t>(y - b.y_first) * b.W;
        const __m256d r = _mm256_set1_pd(row_value(t.plane, y));
        for (int x = x0; x < x1; x += 8) {
            const int n = x1 - x < 8 ? x1 - x : 8;
            const int all = (1 << n) - 1;
            __m256i a, k8;
            const int mask = s.draw(b.A + row, b.K + row, b.B + row, r, x, n, a, k8);
            alignas(32) std::uint32_t old[8];
            if (mask == all) {
                // Where the source seen changes from one lane to the next, a run ends.
                const __m256i before = _mm256_blend_epi32(_mm256_permutevar8x32_epi32(a, previous_lane),
                                                          _mm256_set1_epi32(static_cast<int>(seen.current)), 1);
                const int same = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(a, before))) & all;
                if (same == all) {
                    seen.run += static_cast<std::uint32_t>(n);
                    continue;
                }
                _mm256_store_si256(reinterpret_cast<__m256i*>(old), a);
                int last = 0;
                for (int changes = all & ~same; changes != 0; changes &= changes - 1) {
                    const int l = __builtin_ctz(static_cast<unsigned>(changes));
                    seen.run += static_cast<std::uint32_t>(l - last);
                    flush_run(seen);
                    seen.current = old[l];
                    last = l;
                }
                seen.run += static_cast<std::uint32_t>(n - last);
                continue;
            }
            _mm256_store_si256(reinterpret_cast<__m256i*>(old), a);
            for (int l = 0; l < n; ++l)
                if ((mask >> l) & 1) count_seen(seen, old[l]);
            hand_back(mask, n, row, x, y, k8, slow);
        }
    });
    counts = seen;
}
#undef RB_AVX2
#endif

}  // namespace

std::uint32_t span_key(const DepthPlane& plane, int x, int y) {
    return static_cast<std::uint32_t>(key_at(row_value(plane, y), plane, x));
}

void flush_run(SourceCounts& s) {
    if ((s.current & kSourceBit) != 0 && s.run > 0) {
        const std::uint32_t j = s.current & ~kSourceBit;
        if (s.counts[j] == 0) s.touched[s.touched_count++] = j;
        s.counts[j] += s.run;
    }
    s.run = 0;
}

const SpanKernels& portable_span_kernels() {
    static const SpanKernels k{"portable", source_portable, receiver_portable};
    return k;
}

const SpanKernels& best_span_kernels() {
#ifdef RAYBUNDLE_AVX2_KERNELS
    static const SpanKernels avx2{"avx2", source_avx2, receiver_avx2};
    if (__builtin_cpu_supports("avx2")) return avx2;
#endif
    return portable_span_kernels();
}

}  // namespace raybundle::visibility
