#pragma once
// Exact scan conversion of projected triangles for the discrete visibility maps.
//
// Vertices are snapped to a fixed-point grid of 1/kSubpixel pixel, so every edge
// function has integer coefficients and is evaluated exactly in 64-bit integers. A
// top-left style tie rule assigns every pixel centre on a shared edge to exactly one
// of the two triangles: a watertight mesh covers each pixel centre inside it exactly
// once (no cracks, no double counting).
//
// The run of a row is bounded by the three edges' half-planes. Each edge's boundary
// column, floor(N(y) / D) with N linear in the row, is stepped from row to row with an
// exact quotient-and-remainder DDA: no division, rounding or tie test per row.
#include <algorithm>
#include <cstdint>
#include <utility>

namespace raybundle::visibility {

constexpr double kSubpixel = 256.0;

namespace detail {

inline std::int64_t floor_div(std::int64_t n, std::int64_t d) {  // d > 0
    std::int64_t q = n / d;
    if (n % d < 0) --q;
    return q;
}

// floor(N(y) / D) for N(y) = N0 + dN * (y - y_first), stepped one row at a time.
struct EdgeStep {
    std::int64_t q, r, dq, dr, D;
    void start(std::int64_t n0, std::int64_t dn, std::int64_t d) {
        D = d;
        q = floor_div(n0, d);
        r = n0 - q * d;
        dq = floor_div(dn, d);
        dr = dn - dq * d;
    }
    void step() {
        q += dq;
        r += dr;
        const bool carry = r >= D;
        q += carry;
        r -= carry ? D : 0;
    }
};

}  // namespace detail

// Calls span(y, x_begin, x_end) for every row y in [wy0, wy1) whose pixel centres
// (x + 1/2, y + 1/2) inside the triangle and in the window's columns [wx0, wx1) form
// the non-empty run [x_begin, x_end). X, Y: vertex positions in sub-pixel units
// (integers stored in doubles, |value| < 2^24).
// (Always inlined: the exact painter's kernels inline it into code compiled for AVX2.)
template <class Span>
#if defined(__GNUC__) || defined(__clang__)
__attribute__((always_inline))
#endif
inline void rasterize_triangle(const double Xd[3], const double Yd[3], int wx0, int wx1, int wy0, int wy1,
                               Span&& span) {
    constexpr std::int64_t S = static_cast<std::int64_t>(kSubpixel), H = S / 2;
    std::int64_t X[3], Y[3];
    for (int k = 0; k < 3; ++k) {
        X[k] = static_cast<std::int64_t>(Xd[k]);
        Y[k] = static_cast<std::int64_t>(Yd[k]);
    }
    int b = 1, c = 2;
    const std::int64_t area2 = (X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0]);
    if (area2 == 0) return;
    if (area2 < 0) std::swap(b, c);  // counter-clockwise from here on

    const std::int64_t ymin = std::min({Y[0], Y[1], Y[2]}), ymax = std::max({Y[0], Y[1], Y[2]});
    // Rows whose centres y S + H lie in [ymin, ymax], clipped to the window.
    const int y0 = std::max<std::int64_t>(wy0, -detail::floor_div(-(ymin - H), S));
    const int y1 = std::min<std::int64_t>(wy1 - 1, detail::floor_div(ymax - H, S));
    if (y0 > y1) return;

    // Edge k from e0 to e1: a pixel centre P is inside when
    //   -dy Px + dx Py + (dy X0 - dx Y0) + tie >= 1,   tie = 1 if the edge owns ties.
    // Left edges (dy < 0) bound the run from below, right edges (dy > 0) from above,
    // horizontal edges (dy = 0) admit a whole row or nothing.
    const int e0[3] = {0, b, c}, e1[3] = {b, c, 0};
    detail::EdgeStep left[2], right[2];
    int n_left = 0, n_right = 0;
    std::int64_t flat_b[2], flat_c[2];  // horizontal edges: inside when flat_b * Py + flat_c >= 1
    int n_flat = 0;
    const std::int64_t py0 = y0 * S + H;
    for (int k = 0; k < 3; ++k) {
        const std::int64_t dx = X[e1[k]] - X[e0[k]], dy = Y[e1[k]] - Y[e0[k]];
        const std::int64_t C = dy * X[e0[k]] - dx * Y[e0[k]] + ((dy > 0 || (dy == 0 && dx < 0)) ? 1 : 0);
        if (dy < 0) {
            // A = -dy > 0: x >= (1 - C - dx Py - A H) / (A S)  ->  lo = ceil(M / D) = floor((M + D - 1) / D)
            const std::int64_t A = -dy, D = A * S;
            left[n_left++].start(1 - C - dx * py0 - A * H + D - 1, -dx * S, D);
        } else if (dy > 0) {
            // A' = dy > 0: x <= (C + dx Py - 1 - A' H) / (A' S)  ->  hi = floor(N / D)
            const std::int64_t D = dy * S;
            right[n_right++].start(C + dx * py0 - 1 - dy * H, dx * S, D);
        } else {
            flat_b[n_flat] = dx;
            flat_c[n_flat++] = C;
        }
    }

    for (int y = y0;; ++y) {
        std::int64_t lo = wx0, hi = wx1 - 1;
        for (int k = 0; k < n_left; ++k) lo = std::max(lo, left[k].q);
        for (int k = 0; k < n_right; ++k) hi = std::min(hi, right[k].q);
        for (int k = 0; k < n_flat; ++k)
            if (flat_b[k] * (y * S + H) + flat_c[k] < 1) hi = lo - 1;
        if (lo <= hi) span(y, static_cast<int>(lo), static_cast<int>(hi) + 1);
        if (y == y1) break;
        for (int k = 0; k < n_left; ++k) left[k].step();
        for (int k = 0; k < n_right; ++k) right[k].step();
    }
}

// The whole map [0, width) x [0, height) as the window.
template <class Span>
inline void rasterize_triangle(const double X[3], const double Y[3], int width, int height, Span&& span) {
    rasterize_triangle(X, Y, 0, width, 0, height, std::forward<Span>(span));
}

}  // namespace raybundle::visibility
