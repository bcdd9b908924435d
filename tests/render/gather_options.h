#pragma once
// The final gather these tests were written against: the guide sample alone (spp 1),
// 16 light samples per camera sample, no camera rays apart for emission. The library's
// defaults (render::GatherOptions{}) are the run's instead: 16 samples per pixel, 8
// light samples, 64 emission rays.
#include "render/final_gather.h"

inline raybundle::render::GatherOptions guide_only_gather() {
    raybundle::render::GatherOptions o;
    o.spp = 1;
    o.direct_samples = 16;
    o.emission_samples = 0;
    return o;
}
