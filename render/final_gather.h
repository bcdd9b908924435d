#pragma once
// The final gather with guided image filtering (003: Bauszat, Eisemann, Magnor).
//
// Every pixel's light is computed from the solved radiance field instead of read off
// the patches, split as 003 section 3.1 does:
//
//   L = Le + L_direct + albedo * E_indirect
//
//  - Direct light per camera sample: `direct_samples` pairs of samples combined by
//    multiple importance sampling (balance heuristic): a point on an emissive patch,
//    chosen in proportion to its power and uniform on the triangle, with a shadow
//    ray; and a cosine-weighted direction, which counts if it hits an emitter's front.
//    (Light sampling alone has unbounded variance next to a seam with an emitting
//    wall, seen edge-on from the seam; the directions cover that near field.) Every
//    point light exactly, with one shadow ray. The full BRDF.
//  - Indirect light only at the guide sample of every pixel (the ray through its
//    centre, 003 section 3.2): `gather_rays` cosine-weighted rays; each hit gives the
//    radiance the solved field reflects there (interpolated smoothly across the
//    patch; its emission excluded, since direct light is counted above; nothing from
//    the back of a patch; the sky's radiance where a ray leaves the scene, so that
//    sky light counts here, gathered and filtered). Their mean is the incident
//    indirect radiance E (the cosine-weighted irradiance divided by pi), an image
//    that the guided filter cleans with the guide sample's normal (3 channels) and
//    depth (scaled to [0, 1] by the eye's distance to the far side of the scene's
//    bounding sphere).
//  - Further samples of a pixel (spp > 1, uniform in the pixel) compute their own
//    direct light and take E from the most similar of the four guide pixels around
//    them: similarity s = s_n s_d with s_n = 1 - |N_a - N_i|^2 / max_j |N_a - N_j|^2
//    and s_d = 1 - |D_a - D_i| / max_j |D_a - D_j| (eq. 3-5; no thresholds). The pixel
//    is the box average of its samples.
//
// The indirect term uses the diffuse albedo: at glossy surfaces only the diffuse part
// of the BRDF reflects indirect light, and a glossy scene's field, which holds the
// radiance towards the camera, stands in for the radiance towards the gather point.
// Both are approximations, exact for diffuse scenes.
//
// Reproducible: pixel p draws from its own streams (sampling/streams.h) whatever the
// thread count, so the same seed gives the same image and there is no flicker between
// runs.
#include "render/camera.h"
#include "render/filters.h"
#include "render/image.h"
#include "sampling/run.h"
#include "scenes/ray_caster.h"
#include "solver/radiance_field.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace raybundle::render {

struct GatherOptions {
    int gather_rays = 64;     // N, per guide sample
    int direct_samples = 16;  // K, per camera sample
    int spp = 1;              // camera samples per pixel (the first is the guide)
    FilterOptions filter;     // what cleans the indirect light (render/filters.h)
};

struct GatherResult {
    Image image;              // the final image
    Image direct;             // direct light of the guide samples (plus emission)
    Image indirect;           // noisy incident indirect radiance E at the guide samples
    Image indirect_filtered;  // E after the filter (= indirect with Filter::none)
    Image normal;             // guide normals (unit; zero for background)
    Image depth;              // guide depth (distance from the eye; zero for background)
    Image position;           // guide hit point (world space; zero for background)
    long camera_rays = 0, shadow_rays = 0, gather_rays = 0;
    // Extra samples that took their indirect light from a guide (spp > 1), and those
    // of them whose guide's depth differs from theirs by more than 10 % (a lookup
    // across a depth discontinuity: the case 003 Fig. 3b warns of, where no guide lies
    // on the sample's surface).
    long lookups = 0, lookups_across = 0;
    double seconds_guides = 0.0, seconds_filter = 0.0, seconds_samples = 0.0;
};

// The scene's camera size decides the image size. Seed, threads and progress ("final
// gather" by rows of guide samples, "filter", "final gather" again for further
// samples) come from `run`. Throws OptionError for options it cannot use.
GatherResult final_gather(const scenes::Scene& scene, const scenes::RayCaster& caster,
                          const solver::RadianceField& field, const PinholeCamera& camera,
                          const GatherOptions& options, const sampling::RunOptions& run);

// The geometry-aware lookup (eq. 3-5): of up to four candidate guide samples (normal,
// depth), the index of the most similar to (normal, depth); -1 if there are none.
// Ties go to the earlier candidate.
int most_similar_guide(const scenes::Vec3& normal, double depth, const std::vector<scenes::Vec3>& normals,
                       const std::vector<double>& depths);

}  // namespace raybundle::render
