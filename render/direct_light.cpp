#include "render/direct_light.h"

#include "scenes/brdf.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;

namespace {

Rgb lobe_brdf(Lobe lobe, const scenes::Material& m, const Vec3& n, const Vec3& w_in, const Vec3& w_out) {
    return lobe == Lobe::full ? scenes::brdf(m, n, w_in, w_out) : scenes::brdf_glossy(m, n, w_in, w_out);
}

double lobe_pdf(Lobe lobe, const scenes::Material& m, const Vec3& n, const Vec3& w_out, const Vec3& w) {
    return lobe == Lobe::full ? scenes::brdf_pdf(m, n, w_out, w) : scenes::glossy_pdf(m, n, w_out, w);
}

}  // namespace

DirectLighting::DirectLighting(const scenes::Scene& scene, const scenes::RayCaster& caster)
    : scene_(scene), caster_(caster), patches_(scene.patch_list()), lights_(scene),
      offset_(1e-5 * scene.bounds_radius()) {}

Vec3 DirectLighting::shading_normal(std::size_t p, double b1, double b2, const Vec3& to_eye) const {
    const Vec3 n = scene_.shading_normal(p, b1, b2);
    return n.dot(to_eye) > 0.0 ? n : patches_[p].normal;
}

AreaLights::Sample DirectLighting::draw_light(sampling::Rng& rng) const {
    // In this order: the one GCC gave the call sample(rng.uniform(), rng.uniform(),
    // rng.uniform()) this replaces (arguments right to left), whose order another
    // compiler was free to change.
    const double u2 = rng.uniform(), u1 = rng.uniform(), pick = rng.uniform();
    return lights_.sample(pick, u1, u2);
}

AreaLights::Sample DirectLighting::stratified_light(int k, int samples, sampling::Rng& rng) const {
    const double pick = (k + rng.uniform()) / samples;
    const double u1 = rng.uniform(), u2 = rng.uniform();
    return lights_.sample(pick, u1, u2);
}

void DirectLighting::add_light_point(const Surface& at, const AreaLights::Sample& s, Lobe lobe, const Rgb& weight,
                                     Rgb& sum, long& rays) const {
    const Vec3 d = s.point - at.from;
    const double r = d.norm();
    const Vec3 w = d / r;
    const double cos_x = at.normal.dot(w), cos_y = -patches_[s.patch].normal.dot(w);
    if (!(r > 0.0 && cos_x > 0.0 && cos_y > 0.0)) return;
    ++rays;
    if (!visible(at.from, w, r)) return;
    const double pdf = lights_.pdf_solid_angle(s.patch, r, cos_y) + lobe_pdf(lobe, at.material, at.normal, at.to_eye, w);
    sum += weight * lobe_brdf(lobe, at.material, at.normal, -w, at.to_eye) * scene_.material_of(s.patch).emission *
           (cos_x / pdf);
}

void DirectLighting::add_lobe_direction(const Surface& at, const Vec3& w, double pdf, Lobe lobe, Rgb& sum,
                                        long& rays) const {
    const double cos_x = at.normal.dot(w);
    if (cos_x <= 0.0 || pdf <= 0.0) return;
    ++rays;
    const auto hit = caster_.intersect(at.from, w);
    if (!hit.valid() || lights_.probability(hit.patch) <= 0.0) return;
    const double cos_y = -patches_[hit.patch].normal.dot(w);
    if (cos_y <= 0.0) return;
    const double both = lights_.pdf_solid_angle(hit.patch, hit.t, cos_y) + pdf;
    sum += lobe_brdf(lobe, at.material, at.normal, -w, at.to_eye) * scene_.material_of(hit.patch).emission *
           (cos_x / both);
}

void DirectLighting::add_punctual_lights(const Surface& at, const Rgb& weight, Rgb& sum, long& rays) const {
    for (const auto& light : scene_.point_lights) {
        const Vec3 d = light.position - at.from;
        const double r = d.norm();
        if (!(r > 0.0)) continue;
        const Vec3 w = d / r;
        const double cos_x = at.normal.dot(w);
        const double sent = light.falloff(-w);  // a spot's cone
        if (cos_x <= 0.0 || sent == 0.0) continue;
        ++rays;
        if (!visible(at.from, w, r)) continue;
        sum += weight * scenes::brdf(at.material, at.normal, -w, at.to_eye) * light.intensity * (sent * cos_x / (r * r));
    }
    for (const auto& light : scene_.directional_lights) {
        const Vec3 w = -light.direction;
        const double cos_x = at.normal.dot(w);
        if (cos_x <= 0.0) continue;
        ++rays;
        if (caster_.occluded(at.from, w, 0.0, std::numeric_limits<double>::infinity())) continue;
        sum += weight * scenes::brdf(at.material, at.normal, light.direction, at.to_eye) * light.irradiance * cos_x;
    }
}

// Everything sampled: per sample a point on an emitter and a direction from the BRDF
// (its azimuth or lobe stratified by k), combined by the balance heuristic. (Light
// sampling alone has unbounded variance next to a seam with an emitting wall, seen
// edge-on from the seam; the directions cover that near field.) The full BRDF.
Rgb DirectLighting::sampled(const Surface& at, int samples, sampling::Rng& rng, long& rays) const {
    Rgb sum = Rgb::Zero();
    for (int k = 0; k < samples; ++k) {
        add_light_point(at, stratified_light(k, samples, rng), Lobe::full, Rgb::Ones(), sum, rays);
        const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = (k + rng.uniform()) / samples;
        const auto s = scenes::sample_brdf(at.material, at.normal, at.to_eye, u1, u2, u3);
        add_lobe_direction(at, s.direction, s.pdf, Lobe::full, sum, rays);
    }
    return sum / samples;
}

// The diffuse part exactly, unoccluded (AreaLights::irradiance, light by light), times
// each light's shadow ratio (Heitz, Hill, McGuire 2018): of `samples` points on the
// lights, chosen light by light in proportion to the unoccluded irradiance each gives x
// (stratified), uniform over the part of the light in front of x and above its horizon
// (points elsewhere are drawn again, up to 16 times), the sum of the visible points'
// unshadowed contributions over the sum of all of them.
// A light's points tell its shadow only where they carry its light: their Monte Carlo
// estimate of its unoccluded projected solid angle must reach an eighth of the exact
// one. Where x lies on (or within rounding of) the light's plane, as on the seam of an
// emitting wall, all its light comes from the strip next to x that uniform points never
// meet, and the estimate is orders of magnitude short. Such a light, and one that got
// no usable point, takes the ratio of the points of the lights that passed (of all
// points if none did; 0 if there are none). The glossy part by multiple importance
// sampling of points chosen by power and as many directions from the Phong lobe.
Rgb DirectLighting::analytic(const Surface& at, int samples, sampling::Rng& rng, long& rays) const {
    const scenes::Material& m = at.material;
    const Vec3 &n = at.normal, &from = at.from;
    const std::size_t count = lights_.light_count();
    std::vector<Rgb> unoccluded(count);
    std::vector<double> cdf(count), seen(count, 0.0), all(count, 0.0);
    std::vector<int> attempts(count, 0);
    double total = 0.0;
    for (std::size_t l = 0; l < count; ++l) {
        unoccluded[l] = lights_.irradiance(l, from, n);
        total += unoccluded[l].mean();
        cdf[l] = total;
    }
    Rgb sum = Rgb::Zero();
    if (total > 0.0 && (m.albedo > 0.0).any()) {
        for (int k = 0; k < samples; ++k) {
            const double pick = (k + rng.uniform()) / samples * total;
            const std::size_t l = std::min<std::size_t>(
                static_cast<std::size_t>(std::upper_bound(cdf.begin(), cdf.end(), pick) - cdf.begin()), count - 1);
            for (int attempt = 0; attempt < 16; ++attempt) {
                ++attempts[l];
                const double u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
                const auto s = lights_.sample_light(l, u0, u1, u2);
                const Vec3 d = s.point - from;
                const double r = d.norm();
                if (!(r > 0.0)) continue;
                const Vec3 w = d / r;
                const double cos_x = n.dot(w), cos_y = -patches_[s.patch].normal.dot(w);
                if (cos_x <= 0.0 || cos_y <= 0.0) continue;
                const double contribution = cos_x * cos_y / (r * r);
                all[l] += contribution;
                ++rays;
                if (visible(from, w, r)) seen[l] += contribution;
                break;
            }
        }
        std::vector<bool> told(count);
        double seen_told = 0.0, all_told = 0.0, seen_any = 0.0, all_any = 0.0;
        for (std::size_t l = 0; l < count; ++l) {
            const double area = lights_.light_area(l);
            const double omega = unoccluded[l].mean() / lights_.light_emission(l).mean();
            told[l] = all[l] > 0.0 && area * all[l] / attempts[l] >= omega / 8.0;
            seen_any += seen[l] / area;
            all_any += all[l] / area;
            if (!told[l]) continue;
            seen_told += seen[l] / area;
            all_told += all[l] / area;
        }
        const double fallback = all_told > 0.0 ? seen_told / all_told : all_any > 0.0 ? seen_any / all_any : 0.0;
        Rgb e = Rgb::Zero();
        for (std::size_t l = 0; l < count; ++l) e += unoccluded[l] * (told[l] ? seen[l] / all[l] : fallback);
        sum = m.albedo / M_PI * e;
    }
    if (m.glossy()) {
        Rgb gloss = Rgb::Zero();
        for (int k = 0; k < samples; ++k)
            add_light_point(at, stratified_light(k, samples, rng), Lobe::glossy, Rgb::Ones(), gloss, rays);
        for (int k = 0; k < samples; ++k) {
            const double u1 = rng.uniform(), u2 = (k + rng.uniform()) / samples;
            const auto s = scenes::sample_glossy(m, n, at.to_eye, u1, u2);
            add_lobe_direction(at, s.direction, s.pdf, Lobe::glossy, gloss, rays);
        }
        sum += gloss / samples;
    }
    return sum;
}

}  // namespace raybundle::render
