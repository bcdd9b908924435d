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
// pixels) to a pixel centre; there the exact integer edge test decides. Rounding
// errors are below 1e-12 pixel for maps up to 16384 pixels.
constexpr double kTie = 1e-7;

// Calls span(y, x_begin, x_end) for every row y in [0, height) whose pixel centres
// (x + 1/2, y + 1/2) inside the triangle form the non-empty run [x_begin, x_end).
// X, Y: vertex positions in sub-pixel units (integers stored in doubles).
template <class Span>
inline void rasterize_triangle(const double X[3], const double Y[3], int width, int height, Span&& span) {
    constexpr double S = kSubpixel, H = kSubpixel / 2;
    int a = 0, b = 1, c = 2;
    const double area2 = (X[b] - X[a]) * (Y[c] - Y[a]) - (Y[b] - Y[a]) * (X[c] - X[a]);
    if (area2 == 0.0) return;
    if (area2 < 0.0) std::swap(b, c);  // counter-clockwise from here on

    // Edge k from vertex e0[k] to e1[k]: inside where -dy*Px + dx*Py + C + bias >= 1.
    const int e0[3] = {a, b, c}, e1[3] = {b, c, a};
    double A[3], Bx[3], C[3];
    for (int k = 0; k < 3; ++k) {
        const double dx = X[e1[k]] - X[e0[k]], dy = Y[e1[k]] - Y[e0[k]];
        const bool include_ties = dy > 0 || (dy == 0 && dx < 0);
        A[k] = -dy;
        Bx[k] = dx;
        C[k] = dy * X[e0[k]] - dx * Y[e0[k]] + (include_ties ? 1.0 : 0.0);
    }
    // Per edge, the boundary's x in pixel units is linear in the row: xf(y) = x0 + dxdy * y.
    // It is trusted unless it falls within kTie of a pixel centre, where the exact
    // integer edge test decides.
    double x0[3] = {0, 0, 0}, dxdy[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
        if (A[k] == 0.0) continue;
        // A (x S + H) + Bx (y S + H) + C = 1  <=>  x = ((1 - C - Bx H) / A - H) / S - (Bx / A) y
        x0[k] = ((1.0 - C[k] - Bx[k] * H) / A[k] - H) / S;
        dxdy[k] = -Bx[k] / A[k];
    }
    const int width_last = width - 1;
    // Narrows [lo, hi] to the pixels of row y inside edge k.
    auto bound = [&](int k, int y, double py, int& lo, int& hi) {
        const double off = Bx[k] * py + C[k];  // inside: A*Px + off >= 1
        auto inside = [&](int x) { return A[k] * (x * S + H) + off >= 1.0; };
        const double xf = x0[k] + dxdy[k] * y;
        if (A[k] > 0) {
            double xc = std::ceil(xf);
            if (xc - xf < kTie || xc - xf > 1.0 - kTie) {
                int x = static_cast<int>(std::clamp(xc, 0.0, static_cast<double>(width)));
                while (x <= width_last && !inside(x)) ++x;
                while (x > 0 && inside(x - 1)) --x;
                xc = x;
            }
            lo = std::max(lo, static_cast<int>(std::clamp(xc, 0.0, static_cast<double>(width))));
        } else if (A[k] < 0) {
            double xc = std::floor(xf);
            if (xf - xc < kTie || xf - xc > 1.0 - kTie) {
                int x = static_cast<int>(std::clamp(xc, -1.0, static_cast<double>(width_last)));
                while (x >= 0 && !inside(x)) --x;
                while (x < width_last && inside(x + 1)) ++x;
                xc = x;
            }
            hi = std::min(hi, static_cast<int>(std::clamp(xc, -1.0, static_cast<double>(width_last))));
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

    const int last = width - 1;
    const int y0 = std::max(0, static_cast<int>(std::floor((Y[s[0]] - H) / S)));
    const int y1 = std::min(height - 1, static_cast<int>(std::ceil((Y[s[2]] - H) / S)));
    for (int y = y0; y <= y1; ++y) {
        const double py = y * S + H;
        if (py < Y[s[0]] || py > Y[s[2]]) continue;
        int lo = 0, hi = last;
        if (py == Y[s[0]] || py == Y[s[1]] || py == Y[s[2]]) {
            // The row passes exactly through a vertex: apply all three edge tests.
            for (int k = 0; k < 3 && lo <= hi; ++k) bound(k, y, py, lo, hi);
        } else {
            // Strictly between vertex rows exactly two edges cross: the long one and a short one.
            bound(e_long, y, py, lo, hi);
            bound(py < Y[s[1]] ? e_upper : e_lower, y, py, lo, hi);
        }
        if (lo <= hi) span(y, lo, hi + 1);
    }
}

}  // namespace raybundle::visibility
