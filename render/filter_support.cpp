#include "render/filter_support.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace raybundle::render::detail {

namespace {
std::string size_str(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }
}  // namespace
[[noreturn]] void fail(const char* fn, const std::string& what) {
    throw std::invalid_argument(std::string(fn) + ": " + what);
}

std::string str(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

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

void check_edge_filter(const char* fn, const Image& input, const Guide& guide, int threads,
                       std::initializer_list<int> channels, const char* channel_list,
                       std::initializer_list<Sigma> sigmas) {
    check_images(fn, input, guide, threads);
    check_channels(fn, guide, channels, channel_list);
    for (const Sigma& s : sigmas) check_sigma(fn, s.name, s.value);
    channel_range(fn, "guide", guide.data, guide.channels, guide.width);
    channel_range(fn, "input", input.rgb, 3, input.width);
}

namespace {

// Per-channel minimum and maximum of an image with N interleaved channels, and whether
// every value is finite. Blocks of lcm(N, 4) floats go through four-lane vectors, so
// that every lane always sees the same channel.
template <int N>
void scan_range(const Buffer<float>& data, float* lo, float* hi, bool& finite) {
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

}  // namespace

Range channel_range(const char* fn, const char* what, const Buffer<float>& data, int channels, int width) {
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

}  // namespace raybundle::render::detail
