#pragma once
// Image error metrics against a reference. Sums run over all pixels and channels.
//
// Relative L1 per pixel mixes noise and bias; the block measures tell them apart: the
// means of k x k blocks average the grain away and keep what is wrong over a region
// (light leaking into a contact shadow), which is what a viewer sees at a distance.
#include "render/image.h"

#include <vector>

namespace raybundle::render {

// Sum |a - b| / sum |b| over all pixels and channels.
double relative_l1(const Image& a, const Image& reference);
// Mean squared error over all pixels and channels.
double mse(const Image& a, const Image& reference);
// The relative L1 of the means of k x k-pixel blocks, per channel: sum over blocks and
// channels of |sum_block a - sum_block b| over sum |sum_block b|. Blocks cut by the
// image's right or bottom edge are left out; an image smaller than one block gives 0.
double block_relative_l1(const Image& a, const Image& reference, int k);
// The signed relative error of every whole k x k block, over its pixels and channels
// together (+0.05: 5 % too bright; 0 where the reference sums to 0), row by row from
// the top: (width / k) blocks a row, (height / k) rows.
std::vector<double> block_errors(const Image& a, const Image& reference, int k);
// The one of them largest in magnitude (0 if there is no whole block).
double worst_block(const Image& a, const Image& reference, int k);

// The yardsticks the command line and the bench report: the above with blocks of 4
// and 16 pixels.
struct ImageError {
    double relative_l1 = 0.0, mse = 0.0, block4_l1 = 0.0, worst_block16 = 0.0;
};
ImageError image_error(const Image& a, const Image& reference);

}  // namespace raybundle::render
