#pragma once
// A linear RGB float image, rows top to bottom.
#include "scenes/buffer.h"

#include <Eigen/Core>

#include <vector>

namespace raybundle::render {

struct Image {
    int width = 0, height = 0;
    Buffer<float> rgb;  // 3 floats per pixel

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgb(static_cast<std::size_t>(3) * w * h, 0.0f) {}
    // Sized but not written, for an image whose every pixel the threads then write (they
    // touch its memory first: scenes/buffer.h).
    struct Unfilled {};
    Image(int w, int h, Unfilled) : width(w), height(h), rgb(static_cast<std::size_t>(3) * w * h) {}
    float* at(int x, int y) { return &rgb[3 * (static_cast<std::size_t>(y) * width + x)]; }
    const float* at(int x, int y) const { return &rgb[3 * (static_cast<std::size_t>(y) * width + x)]; }
};

}  // namespace raybundle::render
