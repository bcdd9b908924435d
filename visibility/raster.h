#pragma once
// Exact scan conversion of projected triangles for the discrete visibility maps.
//
// Vertices are snapped to a fixed-point grid of 1/kSubpixel pixel; edge functions of
// such integer coordinates are exact in double precision (all values < 2^53), and a
// top-left style tie rule assigns every pixel centre on a shared edge to exactly one
// of the two triangles. A watertight mesh therefore covers each pixel centre inside
// it exactly once: no cracks, no double counting.
#include <algorithm>
#include <cmath>
#include <utility>

namespace raybundle::visibility {

constexpr double kSubpixel = 256.0;
// Boundaries computed in floating point are trusted unless they fall this close (in
// pixels) to a pixel centre; there the exact integer edge test decides. Their
// rounding errors stay below 1e-9 pixel for maps up to 16384 pixels.
constexpr double kTie = 1e-7;

// floor and ceil for values well inside the int range, without a libm call (the
// baseline x86-64 target has no rounding instruction, and these run once per row).
inline double fast_floor(double v) {
    const double t = static_cast<double>(static_cast<long long>(v));
    return t > v ? t - 1.0 : t;
}
inline double fast_ceil(double v) {
    const double t = static_cast<double>(static_cast<long long>(v));
    return t < v ? t + 1.0 : t;
}
// Keeps a boundary estimate in a range where the conversions above are exact.
inline double clamp_estimate(double v) { return std::clamp(v, -1e9, 1e9); }

// Calls span(y, x_begin, x_end) for every row y in [wy0, wy1) whose pixel centres
// (x + 1/2, y + 1/2) inside the triangle and in the window's columns [wx0, wx1) form
// the non-empty run [x_begin, x_end). X, Y: vertex positions in sub-pixel units
// (integers stored in doubles).
template <class Span>
inline void rasterize_triangle(const double X[3], const double Y[3], int wx0, int wx1, int wy0, int wy1,
                               Span&& span) {
    constexpr double S = kSubpixel, H = kSubpixel / 2;
    int a = 0, b = 1, c = 2;
    const double area2 = (X[b] - X[a]) * (Y[c] - Y[a]) - (Y[b] - Y[a]) * (X[c] - X[a]);
    if (area2 == 0.0) return;
    if (area2 < 0.0) std::swap(b, c);  // counter-clockwise from here on

    // Edge k from vertex e0[k] to e1[k]: inside where -dy*Px + dx*Py + C + bias >= 1.
    const int e0[3] = {a, b, c}, e1[3] = {b, c, a};
    double A[3], Bx[3], C[3], bias[3];
    for (int k = 0; k < 3; ++k) {
        const double dx = X[e1[k]] - X[e0[k]], dy = Y[e1[k]] - Y[e0[k]];
        bias[k] = (dy > 0 || (dy == 0 && dx < 0)) ? 1.0 : 0.0;  // this edge owns ties
        A[k] = -dy;
        Bx[k] = dx;
        C[k] = dy * X[e0[k]] - dx * Y[e0[k]] + bias[k];
    }
    // Per edge, where the exact test flips along a row, in pixel units:
    //   Px* = X0 + (py - Y0) dx/dy - (1 - bias)/dy,  x = (Px* - H) / S,
    // measured from the edge's own start vertex, so nothing large cancels: the error
    // stays below 1e-9 pixel even for 16384-pixel maps. The estimate is trusted unless
    // it falls within kTie of a pixel centre; there the exact integer test decides.
    double slope[3] = {0, 0, 0}, base[3] = {0, 0, 0}, ystart[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
        if (A[k] == 0.0) continue;
        const double dy = -A[k];
        slope[k] = Bx[k] / dy;
        base[k] = X[e0[k]] - (1.0 - bias[k]) / dy - H;
        ystart[k] = Y[e0[k]];
    }
    auto estimate = [&](int k, double py) { return (base[k] + (py - ystart[k]) * slope[k]) / S; };
    const int width_last = wx1 - 1;
    const double first = wx0, past = wx1;
    // Narrows [lo, hi] to the pixels of the row at py (sub-pixel units) inside edge k.
    auto bound = [&](int k, double py, int& lo, int& hi) {
        const double off = Bx[k] * py + C[k];  // inside: A*Px + off >= 1
        auto inside = [&](int x) { return A[k] * (x * S + H) + off >= 1.0; };
        const double xf = estimate(k, py);
        if (A[k] > 0) {
            double xc = fast_ceil(clamp_estimate(xf));
            if (xc - xf < kTie || xc - xf > 1.0 - kTie) {
                int x = static_cast<int>(std::clamp(xc, first, past));
                while (x <= width_last && !inside(x)) ++x;
                while (x > wx0 && inside(x - 1)) --x;
                xc = x;
            }
            lo = std::max(lo, static_cast<int>(std::clamp(xc, first, past)));
        } else if (A[k] < 0) {
            double xc = fast_floor(clamp_estimate(xf));
            if (xf - xc < kTie || xf - xc > 1.0 - kTie) {
                int x = static_cast<int>(std::clamp(xc, first - 1.0, past - 1.0));
                while (x >= wx0 && !inside(x)) --x;
                while (x < width_last && inside(x + 1)) ++x;
                xc = x;
            }
            hi = std::min(hi, static_cast<int>(std::clamp(xc, first - 1.0, past - 1.0)));
        } else if (!(off >= 1.0)) {
            hi = -1;
        }
    };
    auto edge_between = [&](int p, int q) {
        for (int k = 0; k < 3; ++k)
            if ((e0[k] == p && e1[k] == q) || (e0[k] == q && e1[k] == p)) return k;
        return 0;
    };
    int s[3] = {0, 1, 2};  // vertices sorted by Y
    if (Y[s[1]] < Y[s[0]]) std::swap(s[0], s[1]);
    if (Y[s[2]] < Y[s[1]]) std::swap(s[1], s[2]);
    if (Y[s[1]] < Y[s[0]]) std::swap(s[0], s[1]);
    const int e_long = edge_between(s[0], s[2]);
    const int e_upper = edge_between(s[0], s[1]), e_lower = edge_between(s[1], s[2]);

    // Strictly between vertex rows exactly two edges cross a row: the long one and the
    // upper or lower short one; one bounds the run on the left (A > 0), the other on
    // the right (A < 0).
    auto sides = [&](int e_short, int& left, int& right) {
        left = A[e_long] > 0 ? e_long : e_short;
        right = A[e_long] > 0 ? e_short : e_long;
    };
    int up_left, up_right, low_left, low_right;
    sides(e_upper, up_left, up_right);
    sides(e_lower, low_left, low_right);

    // Rows whose centres lie in [Y_min, Y_max].
    const int y0 = std::max(wy0, static_cast<int>(fast_ceil((Y[s[0]] - H) / S)));
    const int y1 = std::min(wy1 - 1, static_cast<int>(fast_floor((Y[s[2]] - H) / S)));
    for (int y = y0; y <= y1; ++y) {
        const double py = y * S + H;
        if (py <= Y[s[0]] || py >= Y[s[2]] || py == Y[s[1]]) {
            // Outside, or exactly through a vertex: all three exact edge tests.
            if (py < Y[s[0]] || py > Y[s[2]]) continue;
            int lo = wx0, hi = width_last;
            for (int k = 0; k < 3 && lo <= hi; ++k) bound(k, py, lo, hi);
            if (lo <= hi) span(y, lo, hi + 1);
            continue;
        }
        const bool upper = py < Y[s[1]];
        const int l = upper ? up_left : low_left, r = upper ? up_right : low_right;
        const double xl = estimate(l, py), xr = estimate(r, py);
        double lo_f = fast_ceil(clamp_estimate(xl)), hi_f = fast_floor(clamp_estimate(xr));
        int lo, hi;
        if (lo_f - xl < kTie || lo_f - xl > 1.0 - kTie || xr - hi_f < kTie || xr - hi_f > 1.0 - kTie) {
            lo = wx0;
            hi = width_last;
            bound(l, py, lo, hi);
            bound(r, py, lo, hi);
        } else {
            lo = static_cast<int>(std::clamp(lo_f, first, past));
            hi = static_cast<int>(std::clamp(hi_f, first - 1.0, past - 1.0));
        }
        if (lo <= hi) span(y, lo, hi + 1);
    }
}

// The whole map [0, width) x [0, height) as the window.
template <class Span>
inline void rasterize_triangle(const double X[3], const double Y[3], int width, int height, Span&& span) {
    rasterize_triangle(X, Y, 0, width, 0, height, std::forward<Span>(span));
}

}  // namespace raybundle::visibility
