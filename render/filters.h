#pragma once
// Edge-aware image filters for the final gather's noisy indirect light (003 §3.3,
// Table 2): He et al.'s guided image filter with a 1-, 3- or 4-channel guide, the
// cross (joint) bilateral filter and Dammertz et al.'s edge-avoiding À-Trous filter.
//
// Call contract, common to all three:
//  - `input` is the image to clean (RGB); `guide` is a noise-free feature image of the
//    same size (normals, depth, position), interleaved `channels` floats per pixel.
//  - The input and guide are only read; the result is a new image of the same size.
//  - `threads` (>= 1) splits the rows between std::threads. The result is
//    bit-identical for every thread count.
//  - Bad arguments throw std::invalid_argument with one line that names the function,
//    the parameter and the value; so do non-finite input or guide values (they would
//    poison every window that holds them). An empty image gives an empty result.
//
// Guided filter (He, Sun, Tang 2010; 003 eq. 6-9). In every (2r+1)² window w_k the
// output is a linear function of the guide, q_i = a_kᵀ I_i + b_k, fitted to the input
// p by ridge regression: a_k = (Σ_k + diag(ε))⁻¹ cov_k(I, p), b_k = p̄_k − a_kᵀ Ī_k,
// with Σ_k the C×C covariance of the guide in w_k. Each colour channel gets its own
// a_k, b_k. The output at i averages the coefficients of all windows that contain i:
// q_i = ā_iᵀ I_i + b̄_i. All window means are box filters computed with running sums
// (O(1) per pixel whatever the radius) over BORDER_REFLECT-extended images, exactly as
// OpenCV's cv::ximgproc::guidedFilter does (its boxFilter uses BORDER_REFLECT,
// "fedcba|abcdefgh|hgfedcb"), so the two agree everywhere, borders included, up to
// floating-point rounding (OpenCV works in float). One difference: OpenCV takes at
// most 3 guide channels and, for 3 channels with ε < 0.01, replaces a covariance
// determinant below 1e-6 by 1; here C = 1, 3 or 4 and the solve is always exact
// (closed-form inverse for C = 3, LDLᵀ for C = 4, in double).
//
// Implementation: the guide and input channels are first centred on their mid-range
// (the filter is equivariant to such shifts). Pass 1 slides (2r+1)-row column sums down
// the image and a running sum along each row, solves every window, and hands rows of
// a and b through a ring of 2r+2 rows to pass 2, which box-filters them the same way;
// rows are stored channel-major so that the per-pixel work runs on vectors of pixels.
//
// Determinism and precision of the running sums: every summed value is rounded to an
// integer multiple of a per-channel power-of-two quantum and summed in double, where
// such sums are exact. The quantum is 2^(L−50) (L = ⌈log2((2r+1)²)⌉, i.e. 2^−37 at
// r = 32) times a bound on the channel: its half range for the image channels and
// their products, and for a and b the bounds that follow from the ridge term
// (|a_i| ≤ R/√ε_i with R the input channel's half range, |b| ≤ R·(1 + (Σ h_i²/ε_i)^½)
// with h_i the guide's half ranges). So the box means do not depend on the order of
// summation, which is what makes any split into row bands give the same bits, and do
// not drift over long running sums. The price: the quanta follow the range, so a
// firefly 10⁴ times brighter than the rest coarsens them to about 10⁻⁸ (image sums)
// and 10⁻⁶ (b, the loosest bound) of the other pixels' values at r = 32; the tests
// hold such a case to 1e-6 of a double-precision evaluation.
#include "render/image.h"
#include "scenes/scene.h"

#include <array>
#include <string>
#include <vector>

namespace raybundle::render {

// A feature image: `channels` floats per pixel, interleaved, rows top to bottom.
// Conventions used by the filters: 1 channel = depth, 3 = normal, 4 = normal + depth,
// 6 = normal + position (À-Trous only).
struct Guide {
    int width = 0, height = 0, channels = 0;
    Buffer<float> data;

    Guide() = default;
    Guide(int w, int h, int c) : width(w), height(h), channels(c), data(static_cast<std::size_t>(w) * h * c, 0.0f) {}
    float* at(int x, int y) { return &data[(static_cast<std::size_t>(y) * width + x) * channels]; }
    const float* at(int x, int y) const { return &data[(static_cast<std::size_t>(y) * width + x) * channels]; }
};

// Guided filter with a 1-, 3- or 4-channel guide; `eps` regularises every channel
// alike (ε·I). Typical: radius 24-32, ε = 0.01 for unit normals (003 §4). radius in
// [1, kMaxGuidedRadius], eps > 0.
constexpr int kMaxGuidedRadius = 1024;
Image guided_filter(const Image& input, const Guide& guide, int radius, double eps, int threads = 1);

// The same with one ε per guide channel (size 1 or guide.channels): Σ_k + diag(ε).
// 003 §4 uses 0.01 for the normal channels and 0.01-0.03 for depth.
Image guided_filter(const Image& input, const Guide& guide, int radius, const std::vector<double>& eps,
                    int threads = 1);

// Cross bilateral filter over the (2r+1)² window (pixels outside the image are left
// out and the weights renormalised):
//   w(p, q) = exp(−|p−q|²/2σ_s² − |n_p−n_q|²/2σ_n² − (z_p−z_q)²/2σ_z²)
// with n the guide's normal channels (guides of 3 or 4 channels) and z its depth
// channel (guides of 1 or 4 channels). Cost O(r²) per pixel. All sigmas > 0. The
// bilateral and À-Trous weights use a polynomial exp (relative error below 4e-6) and
// are summed in float.
Image cross_bilateral_filter(const Image& input, const Guide& guide, int radius, double sigma_spatial,
                             double sigma_normal, double sigma_depth, int threads = 1);

// Edge-avoiding À-Trous wavelet filter (Dammertz et al. 2010): `iterations` passes of
// the 5×5 B3-spline kernel h = (1, 4, 6, 4, 1)/16 ⊗ itself with holes, pass i taking
// taps 2^i pixels apart, each tap weighted by
//   exp(−|c_p−c_q|²/σ_c,i²) · exp(−|n_p−n_q|²/σ_n²) · exp(−|x_p−x_q|²/σ_x²)
// where c is the current colour, σ_c,i = 2^−i σ_colour (halved every pass, as the paper
// recommends), n the guide's normal channels (3, 4 or 6 channels) and x its position
// (6 channels) or depth (1 or 4 channels). These are the paper's equations; the shader
// listed in the paper also divides the normal distance by the step width², which lets
// coarse passes blur across creases, and is not done here. Taps outside the image are
// left out. iterations in [1, 16]; sigmas > 0.
Image atrous_filter(const Image& input, const Guide& guide, int iterations, double sigma_colour,
                    double sigma_normal, double sigma_position, int threads = 1);

// ---------------------------------------------------------------- the choice of filter

// Which filter cleans the final gather's indirect light, and its parameters.
enum class Filter { guided, bilateral, atrous, none };
// Their names in the enum's order: parsing, messages and the command line's choices.
inline constexpr std::array<const char*, 4> kFilterNames = {"guided", "bilateral", "atrous", "none"};
// Parses "guided", "bilateral", "atrous" or "none"; throws OptionError("filter").
Filter parse_filter(const std::string& name);
const char* filter_name(Filter f);

struct FilterOptions {
    Filter filter = Filter::guided;
    // Guided filter. 003 section 4 uses radius 24-32, eps 0.01 (normals) and 0.01-0.03
    // (depth) on path-traced noise at 1024 x 768; our gathered noise is finer and a
    // sweep on the 512^2 Cornell box (bench/gather_study, docs/benchmarks.md) puts the
    // least MSE of the indirect light at radius 8, eps 0.001-0.01 (normals, insensitive)
    // and 1e-4 (depth). Against Cycles references the whole image's relative L1 is least
    // at about half that radius (its blur brightens corners and contact lines): see
    // auto_filter_radius().
    int radius = 0;  // also the cross bilateral filter's window; 0: auto_filter_radius()
    double eps_normal = 0.01;
    double eps_depth = 1e-4;
    // Cross bilateral (normal, depth) and A-Trous (colour, normal, position) parameters.
    double sigma_spatial = 4.0, sigma_normal = 0.3, sigma_depth = 0.02;
    int atrous_iterations = 5;
    double sigma_colour = 1.0;  // A-Trous; its position term uses sigma_depth (scaled positions)
};

// The radius the final gather filters with when FilterOptions::radius is 0: the image's
// size over 256 times 3, times (32 / gather rays)^(1/4), at least 1: 3 at 256^2 with 32
// rays, 6 at 512^2. Measured against the Cycles references of the three benchmark
// scenes at 256^2 (docs/final-image.md): radius 2-4 gives the least relative L1 at
// 32-128 gather rays per pass, radius 8 0.1-0.3 % more, no filter 0.6-2.8 % more at 32.
int auto_filter_radius(int width, int height, int gather_rays);

// Filters an incident indirect image with the guide: normal and depth (scaled to
// [0, 1] by depth_scale) for the guided and bilateral filters; normal and position
// (relative to `origin`, scaled by position_scale) for A-Trous, which stops at edges
// in position. Background pixels have zero normal, depth and position.
Image filter_indirect(const Image& indirect, const Image& normal, const Image& depth, const Image& position,
                      const scenes::Vec3& origin, double depth_scale, double position_scale,
                      const FilterOptions& options, int threads);

}  // namespace raybundle::render
