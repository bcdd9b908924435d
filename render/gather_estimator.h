#pragma once
// What the final gather estimates at one surface point seen by a camera sample
// (render/final_gather.h has the three passes that drive it): the direct light
// (render/direct_light.h), the glossy reflection of the solved field, and the incident
// indirect radiance the field reflects along gather rays.
//
// A gather or glossy ray reads the field where it hits, except where the field is a
// poor stand-in: at a glossy surface (the field holds its radiance towards the camera
// only) and at a hit closer than twice the size of the patch it meets (the patch's
// mean radiance differs most from the radiance at the hit point in corners and along
// contact lines). There the path goes on, up to two bounces in a row: one light point
// and one BRDF direction (balance heuristic), what the direction meets reflecting the
// field.
//
// With GatherOptions::correction q > 0 the field is a control variate: where a ray
// reads it, the path goes on with probability q (the first read of a gather or glossy
// ray; later reads with the path weight's largest channel, at most 0.95: Russian
// roulette) and adds (path - field) / probability. The mean is then the scene's light
// whatever the field; single readings, and so single pixels of the indirect image, may
// be negative.
//
// Direct light at the hits (GatherOptions::direct_at_hits): on the patches across which
// the shots' direct light varies, a reading is the field less its direct part
// (RadianceField::direct, both smoothed to the hit point as the field is) plus the
// direct light at the hit point: every point and directional light, and of the area lights an unbiased
// one-ray estimate. Where most of a patch sees the lights, that estimate is the exact
// unoccluded irradiance E0 (render/lights.h) less what a light point drawn by power
// finds blocked, E0 - (1 - V) g / p; elsewhere V g / p. Each is exact where its
// assumption holds (all seen, or all hidden), so the noise stays at the shadows' edges.
//
// The bias probe (GatherOptions::bias_probe): with the correction off, a gather ray is
// also, with a small probability, followed as the correction would follow it, from a
// generator of its own. The difference (corrected - read) / probability is an unbiased
// estimate of the field's error as that ray reads it; it is kept apart (BiasProbe), so
// the image is the same with the probe or without it.
//
// Thread-safe: every method is const; randomness comes from the caller's generator.
#include "render/direct_light.h"
#include "render/final_gather.h"
#include "sampling/rng.h"
#include "scenes/ray_caster.h"
#include "solver/radiance_field.h"

#include <array>
#include <vector>

namespace raybundle::render {

// One guide sample's bias probe: its probability per gather ray, its generator, and
// what indirect() adds: the mean over the sample's gather rays of (corrected - read) /
// rate (0 for rays not probed), and the rays the probe traced.
struct BiasProbe {
    double rate = 0.0;
    sampling::Rng& rng;
    scenes::Rgb error = scenes::Rgb::Zero();
    long rays = 0;
};

class GatherEstimator {
public:
    // The scene, the caster and the field must outlive it. Its corner values and the
    // patches that take their direct light at the hit point are found on `threads`.
    GatherEstimator(const scenes::Scene& scene, const scenes::RayCaster& caster, const solver::RadianceField& field,
                    const GatherOptions& options, int threads = 1);

    // How many patches take their direct light at the hit point (see above); -1 where
    // none can (the option off, or a field without its direct part).
    long direct_at_hits() const { return direct_at_count_; }

    scenes::Vec3 shading_normal(std::size_t p, double b1, double b2, const scenes::Vec3& to_eye) const {
        return lighting_.shading_normal(p, b1, b2, to_eye);
    }
    // Direct light leaving x (on patch p, front side, shading normal n) towards
    // `to_eye`, from `samples` light samples and every point and directional light; its emission not
    // included.
    scenes::Rgb direct(std::size_t p, const scenes::Vec3& x, const scenes::Vec3& n, const scenes::Vec3& to_eye,
                       int samples, sampling::Rng& rng, long& rays) const;
    // Incident indirect radiance at x: the mean over `count` cosine-weighted rays
    // (stratified, sampling/strata.h) of the radiance the field reflects at their hits.
    // With `probe`, its error estimate of those readings (see above).
    scenes::Rgb indirect(std::size_t p, const scenes::Vec3& x, const scenes::Vec3& n, const scenes::Vec3& to_eye,
                         int count, sampling::Rng& rng, long& rays, BiasProbe* probe = nullptr) const;
    // Glossy reflection of the field at x (a glossy material): the mean over `count`
    // directions drawn from the Phong lobe (stratified) of the lobe's weight times the
    // radiance the field reflects at their hits.
    scenes::Rgb glossy(std::size_t p, const scenes::Vec3& x, const scenes::Vec3& n, const scenes::Vec3& to_eye,
                       int count, sampling::Rng& rng, long& rays) const;

private:
    // The radiance arriving at `from` along -w that the solved field reflects (the hit
    // patch's smooth radiance less its emission, which direct light counts; nothing
    // from the back of a patch; the sky where the ray leaves the scene), or bounce_at()
    // where the path goes on.
    scenes::Rgb field_along(const scenes::Vec3& from, const scenes::Vec3& w, sampling::Rng& rng, long& rays,
                            int bounce = 0) const;
    // The same for a ray from `from` along w whose hit is known. `corrected`: where it
    // reads the field, the path goes on with probability go_on and corrects the reading,
    // and so on along the path (by Russian roulette past this read).
    scenes::Rgb arriving(const scenes::RayHit& hit, const scenes::Vec3& from, const scenes::Vec3& w,
                         sampling::Rng& rng, long& rays, int bounce, double go_on, bool corrected) const;
    // The radiance a surface met by a secondary ray sends back towards it, its
    // emission excluded: one light point and one BRDF direction (balance heuristic for
    // the light they meet) plus every point and directional light; what the direction meets reflects
    // the field (field_along).
    scenes::Rgb bounce_at(const scenes::RayHit& hit, const scenes::Vec3& y, const scenes::Vec3& w_out,
                          sampling::Rng& rng, long& rays, int bounce, bool corrected) const;
    // The direct light a diffuse surface met by a secondary ray at y sends back along
    // w_out (see above), its emission excluded.
    scenes::Rgb direct_at_hit(const scenes::RayHit& hit, const scenes::Vec3& y, const scenes::Vec3& w_out,
                              sampling::Rng& rng, long& rays) const;

    const scenes::Scene& scene_;
    const scenes::RayCaster& caster_;
    const Buffer<scenes::Patch>& patches_;
    DirectLighting lighting_;
    bool analytic_;
    bool near_hits_;
    double correction_;
    // Per patch, the field's corner values, less the direct light on the patches marked
    // in direct_at_ (1: E0 less the blocked part, 2: the seen part).
    Buffer<std::array<scenes::Rgb, 3>> corners_;
    std::vector<char> direct_at_;
    long direct_at_count_ = -1;
};

}  // namespace raybundle::render
