#pragma once
// The solved radiance of every patch, and what the renderer needs to show it.
#include "scenes/scene.h"

#include <array>
#include <vector>

namespace raybundle::solver {

struct RadianceField {
    // Per patch: the radiance it sends towards the camera. For purely diffuse scenes
    // this is its (view-independent) radiance.
    std::vector<scenes::Rgb> radiance;
    // With the linear basis: per patch, the radiance at its three corners (the
    // renderer interpolates them). Empty for the constant basis.
    Buffer<std::array<scenes::Rgb, 3>> corners;  // (filled on the threads: scenes/buffer.h)
    // Per patch: the part of `radiance` that is the lights' direct light, reflected
    // (the first shot's and the diffuse shot's: computed once, the same in every
    // chain and round), so that a reader can put a point estimate of the direct light
    // in the place of its patch average (render/gather_estimator.h). It is all of the
    // lights' direct light or empty: empty where the solver does not keep it apart (no
    // shot; area lights without the diffuse shot; the linear basis). Zero for glossy
    // patches.
    std::vector<scenes::Rgb> direct;

    // Patch-area-weighted mean radiance, averaged over the channels.
    double mean_radiance(const scenes::Scene& scene) const;
    // Sum area |L - L_exact| / sum area L_exact over patches and channels.
    double relative_l1_error(const scenes::Scene& scene, double exact) const;
};

}  // namespace raybundle::solver
