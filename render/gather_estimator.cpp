#include "render/gather_estimator.h"

#include "render/shade.h"
#include "sampling/directions.h"
#include "sampling/strata.h"
#include "scenes/brdf.h"
#include "scenes/frame.h"
#include "scenes/threads.h"
#include "solver/radiance_field.h"

#include <algorithm>
#include <cmath>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;

namespace {

// How often a secondary ray goes on before it reads the field, and how near a hit
// must be, in sizes (square roots of the area) of the patch it meets, to go on.
constexpr int kBounces = 2;
constexpr double kNear = 2.0;
// With the correction on, paths end by chance; past this many vertices the field is read
// as it is: a bias of the field's error times the path's weight there, the product of 63
// vertices' BRDF weights (below 1e-6 at an albedo of 0.8; 0.04 only where every vertex
// reflects 0.95 or more).
constexpr int kMostBounces = 64;
// A patch takes its direct light at the hit point where the field's direct part at one
// of its corners differs from the patch's own by more than this share of its radiance.
constexpr double kDirectVaries = 0.1;

// The mean over `count` directions of reading(u1, u2), the directions' points of the
// unit square stratified (sampling/strata.h).
template <class Reading>
Rgb stratified_mean(int count, sampling::Rng& rng, Reading reading) {
    const sampling::Strata strata(count);
    Rgb sum = Rgb::Zero();
    for (int k = 0; k < count; ++k) {
        const double r1 = rng.uniform(), r2 = rng.uniform();
        const auto [u1, u2] = strata.point(k, r1, r2);
        sum += reading(u1, u2);
    }
    return sum / count;
}

}  // namespace

GatherEstimator::GatherEstimator(const scenes::Scene& scene, const scenes::RayCaster& caster,
                                 const solver::RadianceField& field, const GatherOptions& options, int threads)
    : scene_(scene), caster_(caster), patches_(scene.patch_list()), lighting_(scene, caster),
      analytic_(options.direct == DirectLight::analytic), near_hits_(options.near_hits),
      correction_(options.correction) {
    corners_ = field.corners.empty() ? corner_radiance(scene, field, threads) : field.corners;
    if (!options.direct_at_hits || field.direct.size() != field.radiance.size() || !field.corners.empty()) return;
    const std::size_t n = patches_.size();
    solver::RadianceField direct, rest;
    direct.radiance = field.direct;
    rest.radiance.resize(n);
    parallel_bands(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i)
            rest.radiance[i] = field.radiance[i] - field.direct[i];
    });
    const auto direct_corners = corner_radiance(scene, direct, threads);
    const auto rest_corners = corner_radiance(scene, rest, threads);
    direct_at_.assign(n, 0);
    const AreaLights& lights = lighting_.lights();
    parallel_chunks(static_cast<int>(n), threads, [&](int i0, int i1) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
            const auto& m = scene.material_of(i);
            const Rgb& albedo = scene.albedo_of(i);
            if (m.glossy() || m.emissive() || !(albedo > 0.0).any()) continue;
            double spread = 0.0;
            for (const Rgb& c : direct_corners[i]) spread = std::max(spread, (c - field.direct[i]).abs().maxCoeff());
            if (!(spread > kDirectVaries * field.radiance[i].maxCoeff())) continue;
            corners_[i] = rest_corners[i];
            // Which estimate of the area lights: the one exact where all is seen if the
            // patch's direct light is at least half the unoccluded light at its centroid.
            const Vec3& c = patches_[i].centroid;
            const double open = lights.empty() ? 0.0 : (albedo / M_PI * lights.irradiance(c, patches_[i].normal)).mean();
            direct_at_[i] = open > 0.0 && field.direct[i].mean() >= 0.5 * open ? 1 : 2;
        }
    });
    direct_at_count_ = static_cast<long>(std::count_if(direct_at_.begin(), direct_at_.end(), [](auto d) { return d != 0; }));
}

Rgb GatherEstimator::direct(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int samples,
                            sampling::Rng& rng, long& rays) const {
    scenes::Material scratch;
    const DirectLighting::Surface at{scene_.material_at(p, x, scratch), n, lighting_.origin(x, patches_[p].normal, to_eye),
                                     to_eye};
    Rgb sum = Rgb::Zero();
    if (!lighting_.lights().empty() && samples > 0)
        sum = analytic_ ? lighting_.analytic(at, samples, rng, rays) : lighting_.sampled(at, samples, rng, rays);
    lighting_.add_punctual_lights(at, Rgb::Ones(), sum, rays);
    return sum;
}

Rgb GatherEstimator::indirect(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int count,
                              sampling::Rng& rng, long& rays, BiasProbe* probe) const {
    Vec3 u, v;
    scenes::orthonormal_basis(n, u, v);
    const Vec3 from = lighting_.origin(x, patches_[p].normal, to_eye);
    Rgb error = Rgb::Zero();
    const Rgb mean = stratified_mean(count, rng, [&](double u1, double u2) -> Rgb {
        const Vec3 w = sampling::cosine_hemisphere(u1, u2, n, u, v);
        ++rays;
        const auto hit = caster_.intersect(from, w);
        const Rgb read = arriving(hit, from, w, rng, rays, 0, correction_, correction_ > 0.0);
        // The same ray as the correction follows it (go on at the first read), from the
        // probe's own draws.
        if (probe && probe->rng.uniform() < probe->rate)
            error += (arriving(hit, from, w, probe->rng, probe->rays, 0, 1.0, true) - read) / probe->rate;
        return read;
    });
    if (probe) probe->error += error / count;
    return mean;
}

Rgb GatherEstimator::glossy(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int count,
                            sampling::Rng& rng, long& rays) const {
    const auto& m = scene_.material_of(p);
    const Vec3 from = lighting_.origin(x, patches_[p].normal, to_eye);
    return stratified_mean(count, rng, [&](double u1, double u2) -> Rgb {
        const auto s = scenes::sample_glossy(m, n, to_eye, u1, u2);
        const double cos_x = n.dot(s.direction);
        if (cos_x <= 0.0 || s.pdf <= 0.0) return Rgb::Zero();
        ++rays;
        return scenes::brdf_glossy(m, n, -s.direction, to_eye) * (cos_x / s.pdf) *
               field_along(from, s.direction, rng, rays);
    });
}

Rgb GatherEstimator::field_along(const Vec3& from, const Vec3& w, sampling::Rng& rng, long& rays, int bounce) const {
    return arriving(caster_.intersect(from, w), from, w, rng, rays, bounce, correction_, correction_ > 0.0);
}

Rgb GatherEstimator::arriving(const scenes::RayHit& hit, const Vec3& from, const Vec3& w, sampling::Rng& rng,
                              long& rays, int bounce, double go_on, bool corrected) const {
    if (!hit.valid()) return scene_.sky ? scene_.sky->arriving_along(-w) : Rgb::Zero();
    if (patches_[hit.patch].normal.dot(w) >= 0.0) return Rgb::Zero();
    const Vec3 y = from + hit.t * w;
    if (bounce < kBounces && (scene_.material_of(hit.patch).glossy() ||
                              (near_hits_ && hit.t < kNear * std::sqrt(patches_[hit.patch].area))))
        return bounce_at(hit, y, -w, rng, rays, bounce + 1, corrected);
    const auto& c = corners_[hit.patch];
    Rgb field = (1.0 - hit.b1 - hit.b2) * c[0] + hit.b1 * c[1] + hit.b2 * c[2] - scene_.material_of(hit.patch).emission;
    // A marked patch (not emissive) reads the rest of the field and the direct light at
    // y, each unbiased, neither clamped: a round's segment of the field (render/
    // progressive.h) may have a rest below zero, and clamping it would add light.
    if (!direct_at_.empty() && direct_at_[hit.patch])
        field += direct_at_hit(hit, y, -w, rng, rays);
    else
        field = field.max(0.0);
    // The field as a control variate: with probability go_on the path goes on and its
    // difference from the field, divided by go_on, corrects the reading.
    if (corrected && go_on > 0.0 && bounce < kMostBounces && rng.uniform() < go_on)
        return field + (bounce_at(hit, y, -w, rng, rays, bounce + 1, true) - field) / go_on;
    return field;
}

Rgb GatherEstimator::bounce_at(const scenes::RayHit& hit, const Vec3& y, const Vec3& w_out, sampling::Rng& rng,
                               long& rays, int bounce, bool corrected) const {
    const std::size_t q = static_cast<std::size_t>(hit.patch);
    scenes::Material scratch;
    const auto& m = scene_.material_at(q, y, scratch);
    const Vec3 n = lighting_.shading_normal(q, hit.b1, hit.b2, w_out);
    const DirectLighting::Surface at{m, n, lighting_.origin(y, patches_[q].normal, w_out), w_out};
    Rgb L = Rgb::Zero();
    if (!lighting_.lights().empty())
        lighting_.add_light_point(at, lighting_.draw_light(rng), Lobe::full, Rgb::Ones(), L, rays);
    lighting_.add_punctual_lights(at, Rgb::Ones(), L, rays);
    // u3 first: the order GCC gave the one-line call this replaces (sampling/rng.h).
    const double u3 = rng.uniform(), u2 = rng.uniform(), u1 = rng.uniform();
    const auto s = scenes::sample_brdf(m, n, w_out, u1, u2, u3);
    const Vec3& w = s.direction;
    const double cos_x = n.dot(w);
    if (cos_x <= 0.0 || s.pdf <= 0.0) return L;
    const Rgb f = scenes::brdf(m, n, -w, w_out) * (cos_x / s.pdf);
    ++rays;
    const auto next = caster_.intersect(at.from, w);
    if (next.valid() && lighting_.lights().probability(next.patch) > 0.0) {
        const double cos_y = -patches_[next.patch].normal.dot(w);
        if (cos_y > 0.0)
            L += f * scene_.material_of(next.patch).emission * lighting_.emitter_weight(next.patch, next.t, cos_y, s.pdf);
    }
    // Past the first vertex the correction goes on as Russian roulette does: with the
    // probability of the path's weight at this vertex (at most 0.95), so that the
    // weight over the probability stays at most 1 where that weight is at most 0.95
    // (every diffuse surface; a glossy lobe's sample may weigh more).
    const double go_on = corrected ? std::min(0.95, f.maxCoeff()) : 0.0;
    return L + f * arriving(next, at.from, w, rng, rays, bounce, go_on, corrected);
}

Rgb GatherEstimator::direct_at_hit(const scenes::RayHit& hit, const Vec3& y, const Vec3& w_out, sampling::Rng& rng,
                                   long& rays) const {
    const std::size_t q = static_cast<std::size_t>(hit.patch);
    scenes::Material scratch;
    const auto& m = scene_.material_at(q, y, scratch);
    const Vec3 n = lighting_.shading_normal(q, hit.b1, hit.b2, w_out);
    const DirectLighting::Surface at{m, n, lighting_.origin(y, patches_[q].normal, w_out), w_out};
    Rgb L = Rgb::Zero();
    lighting_.add_punctual_lights(at, Rgb::Ones(), L, rays);
    const AreaLights& lights = lighting_.lights();
    if (lights.empty()) return L;
    const bool all_seen = direct_at_[q] == 1;
    Rgb E = all_seen ? lights.irradiance(at.from, n) : Rgb::Zero();
    const double pick = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    const auto s = lights.sample(pick, u1, u2);
    const Vec3 d = s.point - at.from;
    const double r = d.norm();
    const Vec3 wl = d / r;
    const double cos_x = n.dot(wl), cos_y = -patches_[s.patch].normal.dot(wl);
    if (r > 0.0 && cos_x > 0.0 && cos_y > 0.0) {
        // g / p: the light point's irradiance over its density in area.
        const Rgb g = scene_.material_of(s.patch).emission *
                      (cos_x * cos_y / (r * r) * patches_[s.patch].area / lights.probability(s.patch));
        ++rays;
        const bool seen = !caster_.occluded(at.from, wl, 0.0, r * (1.0 - 1e-5));
        if (all_seen && !seen) E -= g;
        if (!all_seen && seen) E += g;
    }
    return L + m.albedo / M_PI * E;
}

}  // namespace raybundle::render
