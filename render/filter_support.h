#pragma once
// What the three image filters share (render/filters.h): argument checks that throw
// one line naming the function, the parameter and the value, and the per-channel
// range of an image (which also rejects non-finite values). Internal to render/.
#include "render/filters.h"

#include <initializer_list>
#include <string>
#include <vector>

namespace raybundle::render::detail {

[[noreturn]] void fail(const char* fn, const std::string& what);
std::string str(double v);
void check_images(const char* fn, const Image& input, const Guide& guide, int threads);
void check_channels(const char* fn, const Guide& guide, std::initializer_list<int> allowed, const char* list);
void check_sigma(const char* fn, const char* name, double v);
struct Sigma {
    const char* name;
    double value;
};
// The edge-aware filters' common checks: images, guide channels, every sigma > 0 and
// finite, and finite pixels in the guide and the input.
void check_edge_filter(const char* fn, const Image& input, const Guide& guide, int threads,
                       std::initializer_list<int> channels, const char* channel_list,
                       std::initializer_list<Sigma> sigmas);

// The smallest and largest value of every channel of an interleaved image.
struct Range {
    std::vector<double> lo, hi;
    double abs_max(int c) const { return std::max(-lo[c], hi[c]); }
};
// Throws on the first non-finite value; `what` names the image in the message.
Range channel_range(const char* fn, const char* what, const Buffer<float>& data, int channels, int width);

}  // namespace raybundle::render::detail
