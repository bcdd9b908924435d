#include "render/final_gather.h"

#include "render/gbuffer.h"
#include "render/lights.h"
#include "render/shade.h"
#include "sampling/directions.h"
#include "sampling/rng.h"
#include "sampling/strata.h"
#include "sampling/streams.h"
#include "scenes/brdf.h"
#include "scenes/errors.h"
#include "scenes/frame.h"
#include "scenes/threads.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;
using Clock = std::chrono::steady_clock;

int most_similar_guide(const Vec3& normal, double depth, const std::vector<Vec3>& normals,
                       const std::vector<double>& depths) {
    const std::size_t n = normals.size();
    if (n == 0) return -1;
    double max_dn = 0.0, max_dd = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        max_dn = std::max(max_dn, (normal - normals[i]).squaredNorm());
        max_dd = std::max(max_dd, std::abs(depth - depths[i]));
    }
    int best = 0;
    double best_s = -1.0;
    for (std::size_t i = 0; i < n; ++i) {
        // A term whose maximum is zero does not discriminate: similarity 1.
        const double sn = max_dn > 0.0 ? 1.0 - (normal - normals[i]).squaredNorm() / max_dn : 1.0;
        const double sd = max_dd > 0.0 ? 1.0 - std::abs(depth - depths[i]) / max_dd : 1.0;
        const double s = sn * sd;
        if (s > best_s) {
            best_s = s;
            best = static_cast<int>(i);
        }
    }
    return best;
}

DirectLight parse_direct_light(const std::string& name) {
    for (std::size_t k = 0; k < kDirectLightNames.size(); ++k)
        if (name == kDirectLightNames[k]) return static_cast<DirectLight>(k);
    throw scenes::OptionError("direct", "unknown direct light method '" + name + "' (analytic | sampled)");
}

const char* direct_light_name(DirectLight d) { return kDirectLightNames[static_cast<std::size_t>(d)]; }

namespace {

// How often a secondary ray goes on before it reads the field, and how near a hit
// must be, in sizes (square roots of the area) of the patch it meets, to go on.
constexpr int kBounces = 2;
constexpr double kNear = 2.0;

class Gatherer {
public:
    Gatherer(const scenes::Scene& scene, const scenes::RayCaster& caster, const solver::RadianceField& field,
             const GatherOptions& options)
        : scene_(scene), caster_(caster), patches_(scene.patch_list()), lights_(scene),
          offset_(1e-5 * scene.bounds_radius()), analytic_(options.direct == DirectLight::analytic),
          near_hits_(options.near_hits) {
        corners_ = field.corners.empty() ? corner_radiance(scene, field) : field.corners;
    }

    // Where secondary rays start: off the surface, and back towards the eye, which
    // sees x, so that a hit point on the seam of two walls (up to rounding on the far
    // side of the other one) starts inside the room.
    Vec3 origin(const Vec3& x, const Vec3& n, const Vec3& to_eye) const { return x + offset_ * (n + to_eye); }

    // The normal that shades patch p at barycentric (b1, b2): its shading normal
    // (scenes/scene.h), or the patch normal where the eye is below the shading normal's
    // horizon (a silhouette of a coarse curved mesh), where the BRDF would be zero.
    Vec3 shading_normal(std::size_t p, double b1, double b2, const Vec3& to_eye) const {
        const Vec3 n = scene_.shading_normal(p, b1, b2);
        return n.dot(to_eye) > 0.0 ? n : patches_[p].normal;
    }

    // Direct light leaving x (on patch p, front side, shading normal n) towards `to_eye`.
    Rgb direct(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int samples, sampling::Rng& rng, long& rays) const {
        const auto& m = scene_.material_of(p);
        const Vec3 from = origin(x, patches_[p].normal, to_eye);
        Rgb sum = Rgb::Zero();
        if (!lights_.empty() && samples > 0)
            sum = analytic_ ? analytic_direct(m, n, from, to_eye, samples, rng, rays)
                            : sampled_direct(m, n, from, to_eye, samples, rng, rays);
        for (const auto& light : scene_.point_lights) {
            const Vec3 d = light.position - from;
            const double r = d.norm();
            if (r <= 0.0) continue;
            const Vec3 w = d / r;
            const double cos_x = n.dot(w);
            if (cos_x <= 0.0) continue;
            ++rays;
            if (caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) continue;
            sum += scenes::brdf(m, n, -w, to_eye) * light.intensity * (cos_x / (r * r));
        }
        return sum;
    }

    // Incident indirect radiance at x (patch p): the mean over `count` cosine-weighted
    // rays (stratified, sampling/strata.h) of the radiance the field reflects at their
    // hits.
    Rgb indirect(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int count, sampling::Rng& rng, long& rays) const {
        Vec3 u, v;
        scenes::orthonormal_basis(n, u, v);
        const Vec3 from = origin(x, patches_[p].normal, to_eye);
        const sampling::Strata strata(count);
        Rgb sum = Rgb::Zero();
        for (int k = 0; k < count; ++k) {
            const double r1 = rng.uniform(), r2 = rng.uniform();
            const auto [u1, u2] = strata.point(k, r1, r2);
            const Vec3 w = sampling::cosine_hemisphere(u1, u2, n, u, v);
            ++rays;
            sum += field_along(from, w, rng, rays);
        }
        return sum / count;
    }

    // Glossy reflection of the field at x (patch p, a glossy material): the mean over
    // `count` directions drawn from the Phong lobe (stratified like indirect()) of the
    // lobe's weight times the radiance the field reflects at their hits.
    Rgb glossy(std::size_t p, const Vec3& x, const Vec3& n, const Vec3& to_eye, int count, sampling::Rng& rng, long& rays) const {
        const auto& m = scene_.material_of(p);
        const Vec3 from = origin(x, patches_[p].normal, to_eye);
        const sampling::Strata strata(count);
        Rgb sum = Rgb::Zero();
        for (int k = 0; k < count; ++k) {
            const double r1 = rng.uniform(), r2 = rng.uniform();
            const auto [u1, u2] = strata.point(k, r1, r2);
            const auto s = scenes::sample_glossy(m, n, to_eye, u1, u2);
            const double cos_x = n.dot(s.direction);
            if (cos_x <= 0.0 || s.pdf <= 0.0) continue;
            ++rays;
            sum += scenes::brdf_glossy(m, n, -s.direction, to_eye) * (cos_x / s.pdf) * field_along(from, s.direction, rng, rays);
        }
        return sum / count;
    }

private:
    // The radiance arriving at `from` along -w that the solved field reflects (the hit
    // patch's smooth radiance less its emission, which direct light counts; nothing
    // from the back of a patch; the sky where the ray leaves the scene). The path goes
    // on instead (bounce_at(), up to kBounces times in a row) where the field is a poor
    // stand-in: at a glossy surface, where it holds the radiance towards the camera
    // only; and at a hit closer than kNear times the hit patch's size, where the
    // patch's mean radiance, which the field holds, differs most from the radiance at
    // the hit point (corners and contact lines, where the light changes within a patch).
    Rgb field_along(const Vec3& from, const Vec3& w, sampling::Rng& rng, long& rays, int bounce = 0) const {
        const auto hit = caster_.intersect(from, w);
        if (!hit.valid()) return scene_.sky ? scene_.sky->arriving_along(-w) : Rgb::Zero();
        if (patches_[hit.patch].normal.dot(w) >= 0.0) return Rgb::Zero();
        if (bounce < kBounces && (scene_.material_of(hit.patch).glossy() ||
                                  (near_hits_ && hit.t < kNear * std::sqrt(patches_[hit.patch].area))))
            return bounce_at(hit, from + hit.t * w, -w, rng, rays, bounce + 1);
        const auto& c = corners_[hit.patch];
        const Rgb L = (1.0 - hit.b1 - hit.b2) * c[0] + hit.b1 * c[1] + hit.b2 * c[2];
        return (L - scene_.material_of(hit.patch).emission).max(0.0);
    }

    // The radiance a surface met by a secondary ray sends back towards it, its
    // emission excluded, estimated with one light sample and one BRDF sample (balance
    // heuristic for the light they meet) plus every point light; what the BRDF sample
    // meets reflects the field (field_along).
    Rgb bounce_at(const scenes::RayHit& hit, const Vec3& y, const Vec3& w_out, sampling::Rng& rng, long& rays,
                      int bounce) const {
        const std::size_t q = static_cast<std::size_t>(hit.patch);
        const auto& m = scene_.material_of(q);
        const Vec3 n = shading_normal(q, hit.b1, hit.b2, w_out);
        const Vec3 from = origin(y, patches_[q].normal, w_out);
        Rgb L = Rgb::Zero();
        if (!lights_.empty()) {
            const auto s = lights_.sample(rng.uniform(), rng.uniform(), rng.uniform());
            const Vec3 d = s.point - from;
            const double r = d.norm();
            const Vec3 w = d / r;
            const double cos_x = n.dot(w), cos_y = -patches_[s.patch].normal.dot(w);
            if (r > 0.0 && cos_x > 0.0 && cos_y > 0.0) {
                ++rays;
                if (!caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid())
                    L += scenes::brdf(m, n, -w, w_out) * scene_.material_of(s.patch).emission *
                         (cos_x / (lights_.pdf_solid_angle(s.patch, r, cos_y) + scenes::brdf_pdf(m, n, w_out, w)));
            }
        }
        for (const auto& light : scene_.point_lights) {
            const Vec3 d = light.position - from;
            const double r = d.norm();
            const Vec3 w = d / r;
            const double cos_x = n.dot(w);
            if (!(r > 0.0) || cos_x <= 0.0) continue;
            ++rays;
            if (!caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid())
                L += scenes::brdf(m, n, -w, w_out) * light.intensity * (cos_x / (r * r));
        }
        const auto s = scenes::sample_brdf(m, n, w_out, rng.uniform(), rng.uniform(), rng.uniform());
        const Vec3& w = s.direction;
        const double cos_x = n.dot(w);
        if (cos_x <= 0.0 || s.pdf <= 0.0) return L;
        const Rgb f = scenes::brdf(m, n, -w, w_out) * (cos_x / s.pdf);
        ++rays;
        const auto next = caster_.intersect(from, w);
        if (next.valid() && lights_.probability(next.patch) > 0.0) {
            const double cos_y = -patches_[next.patch].normal.dot(w);
            if (cos_y > 0.0) {
                const double pl = lights_.pdf_solid_angle(next.patch, next.t, cos_y);
                L += f * scene_.material_of(next.patch).emission * (s.pdf / (s.pdf + pl));
            }
        }
        return L + f * field_along(from, w, rng, rays, bounce);
    }

    // A point of an area light for stratum k of `samples`: the light chosen in the k-th
    // of `samples` equal slices of the power CDF.
    AreaLights::Sample light_sample(int k, int samples, sampling::Rng& rng) const {
        const double pick = (k + rng.uniform()) / samples;
        const double u1 = rng.uniform(), u2 = rng.uniform();
        return lights_.sample(pick, u1, u2);
    }

    // The diffuse part exactly, unoccluded (AreaLights::irradiance, light by light),
    // times each light's shadow ratio (Heitz, Hill, McGuire 2018): of `samples` points
    // on the lights, chosen light by light in proportion to the unoccluded irradiance
    // each gives x (stratified), uniform over the part of the light in front of x and
    // above its horizon (points elsewhere are drawn again, up to 16 times), the sum of
    // the visible points' unshadowed contributions over the sum of all of them.
    // A light's points tell its shadow only where they carry its light: their Monte
    // Carlo estimate of its unoccluded projected solid angle must reach an eighth of the
    // exact one. Where x lies on (or within rounding of) the light's plane, as on the
    // seam of an emitting wall, all its light comes from the strip next to x that
    // uniform points never meet, and the estimate is orders of magnitude short. Such a
    // light, and one that got no usable point, takes the ratio of the points of the
    // lights that passed (of all points if none did; 0 if there are none). The glossy
    // part by multiple importance sampling of points chosen by power and as many
    // directions from the Phong lobe (balance heuristic).
    Rgb analytic_direct(const scenes::Material& m, const Vec3& n, const Vec3& from, const Vec3& to_eye, int samples,
                        sampling::Rng& rng, long& rays) const {
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
                    if (!caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) seen[l] += contribution;
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
            for (int k = 0; k < samples; ++k) {
                const auto s = light_sample(k, samples, rng);
                const Vec3 d = s.point - from;
                const double r = d.norm();
                const Vec3 w = d / r;
                const double cos_x = n.dot(w), cos_y = -patches_[s.patch].normal.dot(w);
                if (!(r > 0.0) || cos_x <= 0.0 || cos_y <= 0.0) continue;
                ++rays;
                if (caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) continue;
                gloss += scenes::brdf_glossy(m, n, -w, to_eye) * scene_.material_of(s.patch).emission *
                         (cos_x / (lights_.pdf_solid_angle(s.patch, r, cos_y) + scenes::glossy_pdf(m, n, to_eye, w)));
            }
            for (int k = 0; k < samples; ++k) {
                const double u1 = rng.uniform(), u2 = (k + rng.uniform()) / samples;
                const auto s = scenes::sample_glossy(m, n, to_eye, u1, u2);
                const Vec3& w = s.direction;
                const double cos_x = n.dot(w);
                if (cos_x <= 0.0 || s.pdf <= 0.0) continue;
                ++rays;
                const auto hit = caster_.intersect(from, w);
                if (!hit.valid() || lights_.probability(hit.patch) <= 0.0) continue;
                const double cos_y = -patches_[hit.patch].normal.dot(w);
                if (cos_y <= 0.0) continue;
                const double pl = lights_.pdf_solid_angle(hit.patch, hit.t, cos_y);
                gloss += scenes::brdf_glossy(m, n, -w, to_eye) * scene_.material_of(hit.patch).emission *
                         (cos_x / (pl + s.pdf));
            }
            sum += gloss / samples;
        }
        return sum;
    }

    // Everything sampled: per sample a point on an emitter and a direction from the
    // BRDF, combined by the balance heuristic. (Light sampling alone has unbounded
    // variance next to a seam with an emitting wall, seen edge-on from the seam; the
    // directions cover that near field.) The full BRDF.
    Rgb sampled_direct(const scenes::Material& m, const Vec3& n, const Vec3& from, const Vec3& to_eye, int samples,
                       sampling::Rng& rng, long& rays) const {
        Rgb sum = Rgb::Zero();
        for (int k = 0; k < samples; ++k) {
            {  // A point on an emitter.
                const auto s = light_sample(k, samples, rng);
                const Vec3 d = s.point - from;
                const double r = d.norm();
                const Vec3 w = d / r;
                const double cos_x = n.dot(w), cos_y = -patches_[s.patch].normal.dot(w);
                if (r > 0.0 && cos_x > 0.0 && cos_y > 0.0) {
                    ++rays;
                    if (!caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) {
                        const double pdf = lights_.pdf_solid_angle(s.patch, r, cos_y) + scenes::brdf_pdf(m, n, to_eye, w);
                        sum += scenes::brdf(m, n, -w, to_eye) * scene_.material_of(s.patch).emission * (cos_x / pdf);
                    }
                }
            }
            {  // A direction from the BRDF (its azimuth or lobe stratified by k).
                const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = (k + rng.uniform()) / samples;
                const auto s = scenes::sample_brdf(m, n, to_eye, u1, u2, u3);
                const Vec3& w = s.direction;
                const double cos_x = n.dot(w);
                if (cos_x <= 0.0 || s.pdf <= 0.0) continue;
                ++rays;
                const auto hit = caster_.intersect(from, w);
                if (!hit.valid() || lights_.probability(hit.patch) <= 0.0) continue;
                const double cos_y = -patches_[hit.patch].normal.dot(w);
                if (cos_y <= 0.0) continue;
                const double pdf = lights_.pdf_solid_angle(hit.patch, hit.t, cos_y) + s.pdf;
                sum += scenes::brdf(m, n, -w, to_eye) * scene_.material_of(hit.patch).emission * (cos_x / pdf);
            }
        }
        return sum / samples;
    }

    const scenes::Scene& scene_;
    const scenes::RayCaster& caster_;
    const std::vector<scenes::Patch>& patches_;
    AreaLights lights_;
    double offset_;
    bool analytic_;
    bool near_hits_;
    std::vector<std::array<Rgb, 3>> corners_;
};

void put(Image& img, int x, int y, const Rgb& c) {
    float* p = img.at(x, y);
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(c[k]);
}
Rgb get(const Image& img, int x, int y) {
    const float* p = img.at(x, y);
    return {p[0], p[1], p[2]};
}

// The rows this process computes: all of them, or its share where the run is spread
// over a team (sampling::Team: rows rank, rank + size, ...); share() then hands every
// member the others' rows of per-row data (H rows of equal size).
class RowShare {
public:
    RowShare(const sampling::Team* team, int rows)
        : team_(team && team->size() > 1 ? team : nullptr), rows_(rows), first_(team_ ? team_->rank() : 0),
          stride_(team_ ? team_->size() : 1), count_(team_ ? team_->rows_of(team_->rank(), rows) : rows) {}
    int count() const { return count_; }
    // The i-th of this process's rows.
    int row(int i) const { return first_ + i * stride_; }
    template <class T>
    void share(std::vector<T>& rows) const {
        if (team_) team_->share_rows(rows.data(), sizeof(T) * (rows.size() / static_cast<std::size_t>(rows_)), rows_);
    }
    void share(Image& image) const { share(image.rgb); }

private:
    const sampling::Team* team_;
    int rows_, first_, stride_, count_;
};

}  // namespace

GatherResult final_gather(const scenes::Scene& scene, const scenes::RayCaster& caster,
                          const solver::RadianceField& field, const PinholeCamera& camera, const GatherOptions& o,
                          const sampling::RunOptions& run) {
    if (o.gather_rays < 1) throw scenes::OptionError("gather_rays", "must be >= 1, got " + std::to_string(o.gather_rays));
    if (o.direct_samples < 0)
        throw scenes::OptionError("direct_samples", "must be >= 0, got " + std::to_string(o.direct_samples));
    if (o.spp < 1) throw scenes::OptionError("spp", "must be >= 1, got " + std::to_string(o.spp));
    if (o.emission_samples < 0)
        throw scenes::OptionError("emission_samples", "must be >= 0, got " + std::to_string(o.emission_samples));
    if (o.glossy_rays < 0)
        throw scenes::OptionError("glossy_rays", "must be >= 0, got " + std::to_string(o.glossy_rays));
    const int W = camera.width(), H = camera.height();
    const Gatherer g(scene, caster, field, o);
    const auto& patches = scene.patch_list();
    GatherResult r;
    r.image = Image(W, H);
    r.direct = Image(W, H);
    r.indirect = Image(W, H);
    r.normal = Image(W, H);
    r.depth = Image(W, H);
    r.position = Image(W, H);
    std::vector<int> guide_patch(static_cast<std::size_t>(W) * H, -1);
    std::vector<long> camera_rays(H, 0), shadow_rays(H, 0), gather_rays(H, 0), lookups(H, 0), across(H, 0);
    // Spread over a team, this process computes its rows in passes 1 and 3, and they
    // are shared after each: every member filters the whole image.
    const RowShare block(run.team, H);

    // Pass 1: the guide sample of every pixel: G-buffer, indirect light, and with
    // spp = 1 (where the guide is the pixel's only sample) direct light.
    const auto t0 = Clock::now();
    const GBuffer gbuffer = make_gbuffer(scene, caster, camera, run.threads);
    long rows_done = 0;
    std::mutex progress_lock;
    auto row_done = [&](const char* phase, const Clock::time_point& start) {
        if (!run.progress) return;
        const std::lock_guard<std::mutex> lock(progress_lock);
        run.report(phase, ++rows_done, block.count(), std::chrono::duration<double>(Clock::now() - start).count());
    };
    parallel_rows(block.count(), run.threads, [&](int row) {
        const int y = block.row(row);
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            ++camera_rays[y];
            const GSample& s = gbuffer.at(x, y);
            const Vec3& d = s.direction;
            if (s.patch < 0 && o.spp == 1) put(r.direct, x, y, background(scene, d));  // the sky, or black
            if (s.patch < 0 || !s.front) continue;                        // a back side: black
            sampling::Rng rng(run.seed, sampling::streams::kGuidePixels(o.pass, p, 32));
            guide_patch[p] = s.patch;
            const Vec3 n = g.shading_normal(s.patch, s.b1, s.b2, -d);
            put(r.normal, x, y, n);
            put(r.depth, x, y, Rgb::Constant(s.depth));
            put(r.position, x, y, s.point);
            if (o.spp == 1) {
                Rgb direct = scene.material_of(s.patch).emission +
                             g.direct(s.patch, s.point, n, -d, o.direct_samples, rng, shadow_rays[y]);
                if (scene.material_of(s.patch).glossy() && o.glossy_rays > 0)
                    direct += g.glossy(s.patch, s.point, n, -d, o.glossy_rays, rng, gather_rays[y]);
                put(r.direct, x, y, direct);
            }
            put(r.indirect, x, y, g.indirect(s.patch, s.point, n, -d, o.gather_rays, rng, gather_rays[y]));
        }
        row_done("final gather", t0);
    });
    for (Image* image : {&r.direct, &r.indirect, &r.normal, &r.depth, &r.position}) block.share(*image);
    block.share(guide_patch);
    const auto t1 = Clock::now();

    // Pass 2: filter the incident indirect light.
    const double depth_scale = 1.0 / ((camera.eye() - scene.bounds_center()).norm() + scene.bounds_radius());
    // Positions (for A-Trous) relative to the scene's centre, over the same scale as depth.
    if (run.progress) run.progress({"filter", 0, 1, 0.0});
    FilterOptions filter = o.filter;
    if (filter.radius == 0) filter.radius = auto_filter_radius(W, H, o.gather_rays);
    r.filter_radius = filter.radius;
    r.indirect_filtered = filter_indirect(r.indirect, r.normal, r.depth, r.position, scene.bounds_center(),
                                          depth_scale, depth_scale, filter, run.threads);
    if (run.progress) run.progress({"filter", 1, 1, std::chrono::duration<double>(Clock::now() - t1).count()});
    const auto t2 = Clock::now();

    // Pass 3: compose. With spp > 1 the pixel is the mean of spp camera samples (on a
    // jittered grid, sampling/strata.h) that compute their own direct light and look
    // the indirect light up at the guides, plus what the camera sees unlit (emission,
    // the sky) from their own rays or from `emission_samples` rays of their own; the
    // direct AOV is the pixel less its indirect light.
    rows_done = 0;
    const sampling::Strata strata(o.spp), emission_strata(std::max(1, o.emission_samples));
    const bool emission_apart = o.emission_samples > 0;
    parallel_rows(block.count(), run.threads, [&](int row) {
        const int y = block.row(row);
        std::vector<Vec3> cand_n;
        std::vector<double> cand_d;
        std::vector<std::pair<int, int>> cand_xy;
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            Rgb sum = Rgb::Zero();
            if (o.spp == 1) {
                sum = get(r.direct, x, y);  // the background's sky, if any, on a guide that met nothing
                if (guide_patch[p] >= 0)
                    sum += scene.material_of(guide_patch[p]).albedo * get(r.indirect_filtered, x, y);
            } else {
                // A stream of its own, so that the guide pass is the same with any spp.
                sampling::Rng rng(run.seed, sampling::streams::kSamplePixels(o.pass, p, 32));
                Rgb direct = Rgb::Zero(), seen = Rgb::Zero();
                for (int s = 0; s < o.emission_samples; ++s) {
                    const double r1 = rng.uniform(), r2 = rng.uniform();
                    const auto [fx, fy] = emission_strata.point(s, r1, r2);
                    const Vec3 d = camera.direction(x + fx, y + fy);
                    ++camera_rays[y];
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid())
                        seen += background(scene, d);
                    else if (patches[hit.patch].normal.dot(d) < 0.0)
                        seen += scene.material_of(hit.patch).emission;
                }
                if (emission_apart) seen /= o.emission_samples;
                for (int s = 0; s < o.spp; ++s) {
                    const double r1 = rng.uniform(), r2 = rng.uniform();
                    auto [fx, fy] = strata.point(s, r1, r2);
                    fx += x;
                    fy += y;
                    const Vec3 d = camera.direction(fx, fy);
                    ++camera_rays[y];
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid() && !emission_apart) {
                        sum += background(scene, d);
                        direct += background(scene, d);
                    }
                    if (!hit.valid() || patches[hit.patch].normal.dot(d) >= 0.0) continue;
                    const Vec3 point = camera.eye() + hit.t * d;
                    const Vec3 n = g.shading_normal(hit.patch, hit.b1, hit.b2, -d);
                    Rgb L = g.direct(hit.patch, point, n, -d, o.direct_samples, rng, shadow_rays[y]);
                    if (!emission_apart) L += scene.material_of(hit.patch).emission;
                    if (scene.material_of(hit.patch).glossy() && o.glossy_rays > 0)
                        L += g.glossy(hit.patch, point, n, -d, o.glossy_rays, rng, gather_rays[y]);
                    direct += L;
                    // The four guide pixels around the sample point.
                    cand_n.clear();
                    cand_d.clear();
                    cand_xy.clear();
                    const int x0 = static_cast<int>(std::floor(fx - 0.5)), y0 = static_cast<int>(std::floor(fy - 0.5));
                    for (int dy = 0; dy < 2; ++dy)
                        for (int dx = 0; dx < 2; ++dx) {
                            const int cx = std::clamp(x0 + dx, 0, W - 1), cy = std::clamp(y0 + dy, 0, H - 1);
                            if (guide_patch[static_cast<std::size_t>(cy) * W + cx] < 0) continue;
                            const float* gn = r.normal.at(cx, cy);
                            cand_n.emplace_back(gn[0], gn[1], gn[2]);
                            cand_d.push_back(r.depth.at(cx, cy)[0]);
                            cand_xy.emplace_back(cx, cy);
                        }
                    const int best = most_similar_guide(n, hit.t, cand_n, cand_d);
                    if (best >= 0) {
                        const auto [bx, by] = cand_xy[static_cast<std::size_t>(best)];
                        L += scene.material_of(hit.patch).albedo * get(r.indirect_filtered, bx, by);
                        ++lookups[y];
                        if (std::abs(cand_d[static_cast<std::size_t>(best)] - hit.t) > 0.1 * hit.t) ++across[y];
                    }
                    sum += L;
                }
                put(r.direct, x, y, direct / o.spp + seen);
                sum = sum / o.spp + seen;
            }
            put(r.image, x, y, sum);
        }
        if (o.spp > 1) row_done("final gather (samples)", t2);
    });
    block.share(r.image);
    block.share(r.direct);
    for (auto* counts : {&camera_rays, &shadow_rays, &gather_rays, &lookups, &across}) block.share(*counts);
    const auto t3 = Clock::now();
    for (int y = 0; y < H; ++y) {
        r.camera_rays += camera_rays[y];
        r.shadow_rays += shadow_rays[y];
        r.gather_rays += gather_rays[y];
        r.lookups += lookups[y];
        r.lookups_across += across[y];
    }
    r.seconds_guides = std::chrono::duration<double>(t1 - t0).count();
    r.seconds_filter = std::chrono::duration<double>(t2 - t1).count();
    r.seconds_samples = std::chrono::duration<double>(t3 - t2).count();
    return r;
}

}  // namespace raybundle::render
