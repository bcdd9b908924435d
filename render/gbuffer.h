#pragma once
// The G-buffer: for every pixel centre, the patch the camera sees there, the point,
// the patch normal, the depth and the barycentric coordinates.
#include "render/camera.h"
#include "scenes/ray_caster.h"

#include <vector>

namespace raybundle::render {

struct GSample {
    int patch = -1;  // -1: background
    scenes::Vec3 point = scenes::Vec3::Zero();
    scenes::Vec3 normal = scenes::Vec3::Zero();
    double depth = 0.0;    // distance from the eye
    double b1 = 0.0, b2 = 0.0;  // barycentric weights of the patch's 2nd and 3rd vertex
    bool front = false;    // the camera sees the patch's front side (one-sided patches)
};

struct GBuffer {
    int width = 0, height = 0;
    std::vector<GSample> samples;
    const GSample& at(int x, int y) const { return samples[static_cast<std::size_t>(y) * width + x]; }
};

GBuffer make_gbuffer(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera);

}  // namespace raybundle::render
