#pragma once
// Image error metrics against a reference.
#include "render/image.h"

namespace raybundle::render {

// Sum |a - b| / sum |b| over all pixels and channels.
double relative_l1(const Image& a, const Image& reference);
// Mean squared error over all pixels and channels.
double mse(const Image& a, const Image& reference);

}  // namespace raybundle::render
