#pragma once
// The pinhole camera of a scene: scenes/camera.h (below render/, since the solver's
// importance sampling casts camera rays too).
#include "scenes/camera.h"

namespace raybundle::render {
using scenes::PinholeCamera;
}  // namespace raybundle::render
