#pragma once
// The final gather with guided image filtering (003: Bauszat, Eisemann, Magnor).
//
// Every pixel's light is computed from the solved radiance field instead of read off
// the patches, split as 003 section 3.1 does:
//
//   L = Le + L_direct + albedo * E_indirect
//
//  - Direct light per camera sample, from `direct_samples` light samples (points on
//    emissive patches chosen by power, uniform on the triangle, with shadow rays):
//    with DirectLight::analytic (the default) the diffuse part is the exact unoccluded
//    irradiance of every area light (render/lights.h) times that light's shadow ratio
//    from the samples (chosen light by light in proportion to the unoccluded light),
//    so noise remains only in penumbrae; the glossy part combines the light samples
//    with as many directions from the Phong lobe by multiple importance sampling
//    (balance heuristic). DirectLight::sampled estimates all of it by sampling: per
//    sample a light point and a direction from the BRDF, balance heuristic. Every point
//    and directional light exactly, with one shadow ray. The full BRDF.
//  - Glossy reflection per camera sample (004 section 10, "per-pixel Phong"): at a
//    glossy surface `glossy_rays` directions drawn from the Phong lobe read the solved
//    field at their hits (its emission excluded, the sky included), weighted by the
//    lobe; not filtered, since it depends on the view.
//  - Indirect light only at the guide sample of every pixel (003 section 3.2; with
//    spp = 1 the ray through its centre, with spp > 1 through a point drawn uniformly
//    from the pixel, anew every pass): `gather_rays` cosine-weighted rays; each hit gives the
//    radiance the solved field reflects there (interpolated smoothly across the
//    patch; its emission excluded, since direct light is counted above; nothing from
//    the back of a patch; the sky's radiance where a ray leaves the scene, so that
//    sky light counts here, gathered and filtered). Their mean is the incident
//    indirect radiance E (the cosine-weighted irradiance divided by pi), an image
//    that the guided filter cleans with the guide sample's normal (3 channels) and
//    depth (scaled to [0, 1] by the eye's distance to the far side of the scene's
//    bounding sphere).
//  - With spp > 1 the pixel is the box average of spp camera samples (a jittered
//    grid, sampling/strata.h), which compute their own direct light and take E from
//    their own pixel's guide where it lies on their surface (same normal, in their
//    tangent plane): drawn as they are, its E has theirs as its mean, so the pixel
//    converges to its box-filtered light. Where the pixel's guide met another surface,
//    the nearest guide on theirs among the nine pixels around; where none is, the most
//    similar of the four guide pixels around the sample point (003 eq. 3-5: similarity
//    s = s_n s_d with s_n = 1 - |N_a - N_i|^2 / max_j |N_a - N_j|^2 and s_d = 1 -
//    |D_a - D_i| / max_j |D_a - D_j|, no thresholds), and of the nine where that one
//    lies across a depth discontinuity (a thin object whose guides all missed it).
//    Guides at the pixels' centres, as 003 has them, leave a bias that no number of
//    passes takes away where E changes within a pixel: rows along a contact line up to
//    40 % too bright in the Cornell box at 256² (docs/final-image.md section 17). The
//    guide sample serves the indirect light and the normal and depth AOVs only. With
//    spp = 1 the guide sample is the
//    pixel. With emission_samples > 0 what the camera sees unlit (emission, the sky)
//    comes from that many rays of their own instead, on a jittered grid: rays that
//    compute no light, so a light's or a window's edge gets many more of them.
//
// The filtered indirect term uses the diffuse albedo; the glossy lobe reflects the
// field per sample as above. Where a gather or glossy ray meets a glossy surface, the
// field holds only that surface's radiance towards the camera, so the path goes on
// there: one light sample and one BRDF sample (balance heuristic), what the latter
// meets reflecting the field, up to two glossy surfaces in a row. (Reading the field
// there instead lost about 5 % of a glossy Cornell box's light.)
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

// How direct light from area lights is computed (see above).
enum class DirectLight { analytic, sampled };
// Their names in the enum's order: parsing, messages and the command line's choices.
inline constexpr std::array<const char*, 2> kDirectLightNames = {"analytic", "sampled"};
DirectLight parse_direct_light(const std::string& name);  // throws OptionError
const char* direct_light_name(DirectLight d);

// The defaults are a run's (render::RunConfig::gather, the command line's flags).
struct GatherOptions {
    int gather_rays = 64;     // N, per guide sample
    int direct_samples = 8;   // K, per camera sample
    int glossy_rays = 16;     // per camera sample on a glossy surface
    DirectLight direct = DirectLight::analytic;
    // Gather rays that hit closer than twice the size of the patch they meet go on
    // one more bounce instead of reading the field there (the contact bias).
    bool near_hits = true;
    // Where a gather or glossy ray reads the field on a patch across which the shots'
    // direct light varies (a shadow's edge, a contact: RadianceField::direct differs
    // between the patch and its corners by more than a tenth of the patch's radiance),
    // it reads the field less that direct light and samples the direct light at the hit
    // point instead (render/gather_estimator.h): the field's patch averages no longer
    // carry light into contact shadows. Needs a field that keeps the direct light apart.
    bool direct_at_hits = true;
    // The probability q with which a secondary ray that reads the field goes on instead
    // and adds (path - field) / q: the field as a control variate, so the image
    // converges to the scene's true light whatever the field's bias (0: the field is
    // read as the answer, and its bias stays in the image). Past that vertex the path
    // goes on by Russian roulette. A fixed q is no default: at 16 s it takes the contact
    // bias out of the Cornell boxes but adds more noise than it removes bias in the rooms
    // lit through a door or a window (docs/final-image.md section 10); the run's
    // correction "auto" (render/run.h) chooses it from the bias probe.
    double correction = 0.0;
    // With the correction off: the probability with which a gather ray is also followed
    // as the correction would follow it, apart from the image, to measure the field's
    // error where the image reads it (render/gather_estimator.h; GatherResult::bias).
    // A probed ray traces a path (its light samples and bounces): 1/16 adds about 10 % to
    // the final gather's rays (docs/final-image.md section 14); 0: no probe, and the
    // estimate is the halves' rule alone.
    double bias_probe = 1.0 / 16.0;
    // With the probe: also make the image as the probe's corrections would correct it
    // (GatherResult::corrected; a second filter pass), for the correction "auto" of
    // render/progressive.h, which sets it.
    bool corrected_image = false;
    int spp = 16;             // camera samples per pixel (the first is the guide)
    // With spp > 1: camera rays per pixel, besides the spp samples, for what the camera
    // sees unlit, emission and the sky (one ray each, no light computed); 0: the spp
    // samples see it. Cheap samples for the brightest edges of an image (a light, a
    // window).
    int emission_samples = 64;
    // Which pass of a progressive image this is (render/progressive.h): its own
    // random streams, below sampling::streams::kMaxPasses.
    std::uint64_t pass = 0;
    FilterOptions filter;     // what cleans the indirect light (render/filters.h)
};

struct GatherResult {
    Image image;              // the final image
    Image direct;             // emission, direct light and glossy reflection (the mean of the camera samples)
    Image indirect;           // noisy incident indirect radiance E at the guide samples
    Image indirect_filtered;  // E after the filter (= indirect with Filter::none)
    Image normal;             // guide normals (unit; zero for background)
    Image depth;              // guide depth (distance from the eye; zero for background)
    Image position;           // guide hit point (world space; zero for background)
    // At the guide samples, an unbiased, noisy estimate of the image's bias in its
    // indirect light: albedo (filtered E - E - D), where D is the bias probe's estimate of
    // the field's error in E (zero without a probe) and filtered E - E the filter's. Its
    // means over blocks of pixels are what render/progressive.h's estimate uses.
    Image bias;
    // Whether it holds the field's error: the probe ran, or the correction took the
    // field's error out of the image (else it holds the filter's departure alone).
    bool bias_probed = false;
    // With the probe and corrected_image: the image as the correction at rate
    // bias_probe would make it (the probe's corrections added to E before the filter,
    // then composed as the image is), free of the field's bias in the gather rays'
    // readings (not in the glossy rays'), noisier; and its bias image (the filter's
    // departure alone). Else empty. render/progressive.h chooses between the two
    // (the correction "auto").
    Image corrected, corrected_bias;
    long camera_rays = 0, shadow_rays = 0, gather_rays = 0, bias_rays = 0;
    // The patches whose direct light the gather samples at its hits (direct_at_hits),
    // and -1 where it does not (off, or a field without its direct part); of the last
    // pass, as the filter's radius.
    long direct_at_hits = -1;
    int filter_radius = 0;  // the radius the filter used (of the last pass: rounds may vary)
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
