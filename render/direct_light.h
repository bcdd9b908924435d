#pragma once
// Direct light at a surface point: one module for the final gather and the path tracer.
//
// Light from the area lights is estimated by multiple importance sampling (Veach 1997,
// the balance heuristic) of two strategies:
//   - a point of a light (AreaLights: a patch by power, uniform on it), with a shadow
//     ray: f Le cos_x / (p_light + p_lobe) where it is seen (add_light_point);
//   - a direction drawn from the BRDF (or its glossy lobe) that meets a light's front:
//     f Le cos_x / (p_light + p_lobe) (add_lobe_direction), or, where the caller
//     carries the throughput f cos_x / p_lobe on (a path), Le p_lobe / (p_lobe + p_light)
//     (emitter_weight).
// Point and directional lights are exact, one shadow ray each (add_punctual_lights). The terms are added
// into the caller's running sum, each led by the caller's weight (a path's throughput),
// so that where they are used the arithmetic is the same, term for term.
//
// The gather's direct estimators (DirectLight, render/final_gather.h) are built on
// them: `sampled` (per sample a light point and a BRDF direction) and `analytic` (the
// diffuse part exact and unoccluded, render/lights.h, times each light's shadow ratio
// from its points; the glossy lobe by the two strategies).
#include "render/final_gather.h"
#include "render/lights.h"
#include "sampling/rng.h"
#include "scenes/ray_caster.h"
#include "scenes/scene.h"

namespace raybundle::render {

// Which part of a material a strategy samples and evaluates.
enum class Lobe { full, glossy };

class DirectLighting {
public:
    // The scene and caster must outlive it.
    DirectLighting(const scenes::Scene& scene, const scenes::RayCaster& caster);

    const AreaLights& lights() const { return lights_; }

    // Where rays leaving x (on a patch of geometric normal `normal`) start: off the
    // surface, and back towards the eye, which sees x, so that a point on the seam of
    // two walls (up to rounding on the far side of the other one) starts inside.
    scenes::Vec3 origin(const scenes::Vec3& x, const scenes::Vec3& normal, const scenes::Vec3& to_eye) const {
        return x + offset_ * (normal + to_eye);
    }
    // The normal that shades patch p at barycentric (b1, b2): its shading normal, or the
    // patch normal where the eye is below the shading normal's horizon (a silhouette of
    // a coarse curved mesh), where the BRDF would be zero.
    scenes::Vec3 shading_normal(std::size_t p, double b1, double b2, const scenes::Vec3& to_eye) const;

    // A surface point as the strategies see it: its material, shading normal, the
    // origin of its rays and the direction it is seen from.
    struct Surface {
        const scenes::Material& material;
        scenes::Vec3 normal, from, to_eye;
    };

    // A point of the area lights, the patch by power (`pick` from rng), uniform on it.
    AreaLights::Sample draw_light(sampling::Rng& rng) const;

    // The light-point strategy: adds weight f Le cos_x / (p_light + p_lobe) where the
    // point s is seen from the surface.
    void add_light_point(const Surface& at, const AreaLights::Sample& s, Lobe lobe, const scenes::Rgb& weight,
                         scenes::Rgb& sum, long& rays) const;
    // The BRDF strategy: w drawn from the lobe with density `pdf`; adds
    // f Le cos_x / (p_light + pdf) where it meets a light's front.
    void add_lobe_direction(const Surface& at, const scenes::Vec3& w, double pdf, Lobe lobe, scenes::Rgb& sum,
                            long& rays) const;
    // The balance weight pdf / (pdf + p_light) of an emitting patch met at distance t,
    // its cosine towards the ray cos_y > 0, by a direction of BRDF density `pdf`.
    double emitter_weight(std::size_t patch, double t, double cos_y, double pdf) const {
        return pdf / (pdf + lights_.pdf_solid_angle(patch, t, cos_y));
    }
    // Every point light: adds weight f I cos_x / r^2 where it is seen; every
    // directional light: weight f E cos_x where its shadow ray leaves the scene.
    void add_punctual_lights(const Surface& at, const scenes::Rgb& weight, scenes::Rgb& sum, long& rays) const;

    // The gather's direct light from the area lights, `samples` of them (DirectLight).
    scenes::Rgb sampled(const Surface& at, int samples, sampling::Rng& rng, long& rays) const;
    scenes::Rgb analytic(const Surface& at, int samples, sampling::Rng& rng, long& rays) const;

private:
    // Whether the segment from `from` to a point at distance r along w is unblocked.
    bool visible(const scenes::Vec3& from, const scenes::Vec3& w, double r) const {
        return !caster_.occluded(from, w, 0.0, r * (1.0 - 1e-5));
    }
    // A point of the lights for stratum k of `samples` equal slices of the power CDF.
    AreaLights::Sample stratified_light(int k, int samples, sampling::Rng& rng) const;

    const scenes::Scene& scene_;
    const scenes::RayCaster& caster_;
    const Buffer<scenes::Patch>& patches_;
    AreaLights lights_;
    double offset_;
};

}  // namespace raybundle::render
