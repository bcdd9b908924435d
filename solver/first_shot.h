#pragma once
// The first shot (004 section 9): the direct effect of point and directional lights,
// computed once and exactly (up to quadrature over each patch) with shadow rays;
// afterwards the lights leave the iteration, and what the patches reflect of them is
// an emission.
//
// The irradiance of patch i from a light of intensity I at p is the patch average of
// I cos(theta) / r^2 times visibility, integrated by the centroid rule on a regular
// split of the patch into N^2 similar triangles, N chosen so that a sub-triangle is
// small against its distance to the light (N = ceil(8 edge / r), 2..64): the
// quadrature error is then well below 1 %.
//
// A directional light (a sun) gives a patch E cos(theta) times its unshadowed share
// (sunlit_share, below).
#include "sampling/run.h"
#include "scenes/ray_caster.h"
#include "scenes/scene.h"

#include <cstdint>
#include <vector>

namespace raybundle::solver {

struct FirstShot {
    // Per patch: irradiance from all point and directional lights (W/m^2 per channel,
    // patch average).
    std::vector<scenes::Rgb> irradiance;
    // Per (glossy patch, light) with light on it: the light's direction of travel to
    // the patch centroid and that light's irradiance, for the view-dependent part.
    struct Hit {
        std::uint32_t patch;
        scenes::Vec3 direction;
        scenes::Rgb irradiance;
    };
    std::vector<Hit> glossy_hits;
    long shadow_rays = 0;
};

// Computes the first shot of every point and directional light of the scene,
// receivers split over `threads` (the same result for any count); glossy hits in
// patch order, each patch's in the lights' order (point lights, then directional).
FirstShot first_shot(const scenes::Scene& scene, const scenes::RayCaster& caster, int threads = 1);

// The share of `patch` that the directional light reaches: the share of shadow rays
// towards the light, from the centroids of N^2 sub-triangles just off its front, that
// leave the scene, N = ceil(32 edge / R) in 4..64 (R: the scene's bounding radius; 4 at
// the automatic patch size), or, where those disagree (a shadow's edge crosses it), of
// (8 N)^2 (at most 65,536) points of a low-discrepancy sequence over it. 0 where the
// patch does not face the light. Adds the rays it casts to `rays`.
double sunlit_share(const scenes::Scene& scene, const scenes::RayCaster& caster, std::size_t patch,
                    const scenes::DirectionalLight& light, long& rays);

// The diffuse shot (004 section 9.1): the direct irradiance of every patch from every
// emissive patch (W/m^2 per channel, patch average), for scenes with medium-sized
// area lights whose direct light a bundle of parallel rays samples poorly. At points
// of the receiver (the centroid rule on N^2 sub-triangles, N = ceil(4 edge / distance),
// 1..16) the emitter's unoccluded form factor is Lambert's closed form (exact, also
// next to a shared edge), times the fraction of shadow rays to points of the emitter
// (N = ceil(2 edge / distance), 1..4) that arrive. Counts its shadow rays in `rays`.
// Receivers are split over run.threads (the same result for any count); progress is
// reported as "diffuse shot", in receivers.
//
// Many emitters (more than 64: a light panel refined with the scene) would make that
// a ray per receiver point and emitter. Then the coplanar emissive patches of one
// object and material form a group, and at each receiver point the group's
// unoccluded form factor (Lambert's edge sum over its outline, clipped to the point's
// plane: solver/form_factor.h) is weighed by the visible share
// of shadow rays shared by all members: K = (4 radius / distance)^2 in 16..64 rays to
// members drawn by area in Morton order (stratified, fixed), each weighed by the
// point-to-point kernel, and 256 where the first K disagree (a shadow's edge). On the
// Cornell box at patch size 10 (121,324 patches, 1,024 emitters) that is 82 million
// shadow rays -> 3.9 million (docs/benchmarks.md).
// `groups`, when given, receives how many groups it made (each emitter alone where
// there are 64 or fewer).
std::vector<scenes::Rgb> diffuse_shot(const scenes::Scene& scene, const scenes::RayCaster& caster, long& rays,
                                      const sampling::RunOptions& run = {}, std::size_t* groups = nullptr);

}  // namespace raybundle::solver
