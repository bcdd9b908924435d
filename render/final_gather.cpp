#include "render/final_gather.h"

#include "render/shade.h"
#include "sampling/directions.h"
#include "scenes/threads.h"
#include "sampling/rng.h"
#include "solver/brdf.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;
using Clock = std::chrono::steady_clock;

Filter parse_filter(const std::string& name) {
    if (name == "guided") return Filter::guided;
    if (name == "bilateral") return Filter::bilateral;
    if (name == "atrous") return Filter::atrous;
    if (name == "none") return Filter::none;
    throw std::invalid_argument("unknown filter '" + name + "' (known: guided, bilateral, atrous, none)");
}

const char* filter_name(Filter f) {
    switch (f) {
        case Filter::guided: return "guided";
        case Filter::bilateral: return "bilateral";
        case Filter::atrous: return "atrous";
        case Filter::none: return "none";
    }
    return "?";
}

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

Image filter_indirect(const Image& indirect, const Image& normal, const Image& depth, const Image& position,
                      const Vec3& origin, double depth_scale, double position_scale, const GatherOptions& o) {
    if (o.filter == Filter::none) return indirect;
    if (o.filter == Filter::atrous) {
        Guide guide(indirect.width, indirect.height, 6);
        for (int y = 0; y < indirect.height; ++y)
            for (int x = 0; x < indirect.width; ++x) {
                float* g = guide.at(x, y);
                const float* n = normal.at(x, y);
                const float* p = position.at(x, y);
                const bool hit = n[0] != 0.0f || n[1] != 0.0f || n[2] != 0.0f;  // background: all zero
                for (int k = 0; k < 3; ++k) {
                    g[k] = n[k];
                    g[3 + k] = hit ? static_cast<float>((p[k] - origin[k]) * position_scale) : 0.0f;
                }
            }
        return atrous_filter(indirect, guide, o.atrous_iterations, o.sigma_colour, o.sigma_normal, o.sigma_depth,
                             o.threads);
    }
    Guide guide(indirect.width, indirect.height, 4);
    for (int y = 0; y < indirect.height; ++y)
        for (int x = 0; x < indirect.width; ++x) {
            float* g = guide.at(x, y);
            const float* n = normal.at(x, y);
            g[0] = n[0];
            g[1] = n[1];
            g[2] = n[2];
            g[3] = static_cast<float>(depth.at(x, y)[0] * depth_scale);
        }
    switch (o.filter) {
        case Filter::guided:
            return guided_filter(indirect, guide, o.radius, {o.eps_normal, o.eps_normal, o.eps_normal, o.eps_depth},
                                 o.threads);
        case Filter::bilateral:
            return cross_bilateral_filter(indirect, guide, o.radius, o.sigma_spatial, o.sigma_normal, o.sigma_depth,
                                          o.threads);
        case Filter::atrous:
        case Filter::none: break;
    }
    return indirect;
}

namespace {

// Runs body(y) for every row, rows split into interleaved bands over `threads`.
template <class F>
void parallel_rows(int height, int threads, F&& body) {
    threads = std::max(1, std::min(threads, height));
    run_threads(threads, [&](int t) {
        for (int y = t; y < height; y += threads) body(y);
    });
}

class Gatherer {
public:
    Gatherer(const scenes::Scene& scene, const scenes::RayCaster& caster, const solver::RadianceField& field)
        : scene_(scene), caster_(caster), patches_(scene.patch_list()), offset_(1e-5 * scene.bounds_radius()) {
        corners_ = field.corners.empty() ? corner_radiance(scene, field) : field.corners;
        // Emitters by power (area times mean emitted radiance), as a CDF.
        double total = 0.0;
        power_.assign(patches_.size(), 0.0);
        for (std::size_t j = 0; j < patches_.size(); ++j) {
            const double power = patches_[j].area * scene.material_of(j).emission.mean();
            if (power <= 0.0) continue;
            total += power;
            power_[j] = power;
            emitters_.push_back(static_cast<std::uint32_t>(j));
            cdf_.push_back(total);
        }
        for (auto& c : cdf_) c /= total;
        for (auto& p : power_) p /= total;  // now the probability of choosing the patch
    }

    // Where secondary rays start: off the surface, and back towards the eye, which
    // sees x, so that a hit point on the seam of two walls (up to rounding on the far
    // side of the other one) starts inside the room.
    Vec3 origin(const Vec3& x, const Vec3& n, const Vec3& to_eye) const { return x + offset_ * (n + to_eye); }

    // Direct light leaving x (on patch p, front side) towards `to_eye`.
    Rgb direct(std::size_t p, const Vec3& x, const Vec3& to_eye, int samples, sampling::Rng& rng, long& rays) const {
        const Vec3& n = patches_[p].normal;
        const auto& m = scene_.material_of(p);
        const Vec3 from = origin(x, n, to_eye);
        Rgb sum = Rgb::Zero();
        if (!emitters_.empty() && samples > 0) {
            // Multiple importance sampling (balance heuristic) of two strategies per
            // sample: a point on an emitter chosen by power, and a cosine-weighted
            // direction. Near a seam with an emitting wall, where the first has
            // unbounded variance, the second takes over.
            const auto& pos = scene_.vertex_positions();
            Vec3 u, v;
            sampling::orthonormal_basis(n, u, v);
            // Solid-angle density of light sampling towards emitter j seen at distance r.
            auto light_pdf = [&](std::uint32_t j, double r, double cos_y) {
                return power_[j] / patches_[j].area * r * r / cos_y;
            };
            // Stratified: sample k picks its emitter in the k-th of `samples` equal slices
            // of the power CDF, and its cosine direction in the k-th slice of azimuth.
            for (int k = 0; k < samples; ++k) {
                {  // A point on an emitter.
                    const double pick = (k + rng.uniform()) / samples;
                    const std::size_t e = std::min<std::size_t>(
                        static_cast<std::size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), pick) - cdf_.begin()),
                        emitters_.size() - 1);
                    const std::uint32_t j = emitters_[e];
                    const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();  // uniform on the triangle
                    const auto& q = patches_[j];
                    const Vec3 y = (1.0 - r1) * pos[q.v[0]] + r1 * (1.0 - r2) * pos[q.v[1]] + r1 * r2 * pos[q.v[2]];
                    const Vec3 d = y - from;
                    const double r = d.norm();
                    const Vec3 w = d / r;
                    const double cos_x = n.dot(w), cos_y = -q.normal.dot(w);
                    if (r > 0.0 && cos_x > 0.0 && cos_y > 0.0) {
                        ++rays;
                        if (!caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) {
                            const double pdf = light_pdf(j, r, cos_y) + cos_x / M_PI;
                            sum += solver::brdf(m, n, -w, to_eye) * scene_.material_of(j).emission * (cos_x / pdf);
                        }
                    }
                }
                {  // A cosine-weighted direction.
                    const double u1 = rng.uniform(), u2 = (k + rng.uniform()) / samples;
                    const double rr = std::sqrt(u1), phi = 2.0 * M_PI * u2;
                    const Vec3 w =
                        rr * std::cos(phi) * u + rr * std::sin(phi) * v + std::sqrt(std::max(0.0, 1.0 - u1)) * n;
                    const double cos_x = n.dot(w);
                    ++rays;
                    const auto hit = caster_.intersect(from, w);
                    if (cos_x > 0.0 && hit.valid() && power_[hit.patch] > 0.0) {
                        const double cos_y = -patches_[hit.patch].normal.dot(w);
                        if (cos_y > 0.0) {
                            const double pdf = light_pdf(static_cast<std::uint32_t>(hit.patch), hit.t, cos_y) +
                                               cos_x / M_PI;
                            sum += solver::brdf(m, n, -w, to_eye) * scene_.material_of(hit.patch).emission *
                                   (cos_x / pdf);
                        }
                    }
                }
            }
            sum /= samples;
        }
        for (const auto& light : scene_.point_lights) {
            const Vec3 d = light.position - from;
            const double r = d.norm();
            if (r <= 0.0) continue;
            const Vec3 w = d / r;
            const double cos_x = n.dot(w);
            if (cos_x <= 0.0) continue;
            ++rays;
            if (caster_.intersect(from, w, 0.0, r * (1.0 - 1e-5)).valid()) continue;
            sum += solver::brdf(m, n, -w, to_eye) * light.intensity * (cos_x / (r * r));
        }
        return sum;
    }

    // Incident indirect radiance at x (patch p): the mean over `count` cosine-weighted
    // rays (stratified on a sqrt(count)^2 grid when count is a square) of the radiance
    // the field reflects at their hits.
    Rgb indirect(std::size_t p, const Vec3& x, const Vec3& to_eye, int count, sampling::Rng& rng, long& rays) const {
        const Vec3& n = patches_[p].normal;
        Vec3 u, v;
        sampling::orthonormal_basis(n, u, v);
        const Vec3 from = origin(x, n, to_eye);
        const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(count))));
        const bool strata = side * side == count;
        Rgb sum = Rgb::Zero();
        for (int k = 0; k < count; ++k) {
            double u1 = rng.uniform(), u2 = rng.uniform();
            if (strata) {
                u1 = ((k % side) + u1) / side;
                u2 = ((k / side) + u2) / side;
            }
            const double r = std::sqrt(u1), phi = 2.0 * M_PI * u2;
            const Vec3 w = r * std::cos(phi) * u + r * std::sin(phi) * v + std::sqrt(std::max(0.0, 1.0 - u1)) * n;
            ++rays;
            const auto hit = caster_.intersect(from, w);
            if (!hit.valid()) {
                // Out into the open: the sky (light from direction w travels along -w).
                if (scene_.sky) sum += scene_.sky->arriving_along(-w);
                continue;
            }
            const auto& q = patches_[hit.patch];
            if (q.normal.dot(w) >= 0.0) continue;  // the back of a patch sends nothing
            const auto& c = corners_[hit.patch];
            const Rgb L = (1.0 - hit.b1 - hit.b2) * c[0] + hit.b1 * c[1] + hit.b2 * c[2];
            sum += (L - scene_.material_of(hit.patch).emission).max(0.0);
        }
        return sum / count;
    }

private:
    const scenes::Scene& scene_;
    const scenes::RayCaster& caster_;
    const std::vector<scenes::Patch>& patches_;
    double offset_;
    std::vector<std::array<Rgb, 3>> corners_;
    std::vector<std::uint32_t> emitters_;
    std::vector<double> cdf_;
    std::vector<double> power_;  // per patch: the probability that light sampling picks it
};

// Random streams of the pixels, apart from the solver's (small stream numbers): the
// guide sample of pixel p draws from kGuideStreams + p, its further samples from
// kSampleStreams + p.
constexpr std::uint64_t kGuideStreams = 1ull << 40, kSampleStreams = 2ull << 40;

void put(Image& img, int x, int y, const Rgb& c) {
    float* p = img.at(x, y);
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(c[k]);
}
Rgb get(const Image& img, int x, int y) {
    const float* p = img.at(x, y);
    return {p[0], p[1], p[2]};
}

}  // namespace

GatherResult final_gather(const scenes::Scene& scene, const scenes::RayCaster& caster,
                          const solver::RadianceField& field, const PinholeCamera& camera, const GatherOptions& o) {
    if (o.gather_rays < 1) throw std::invalid_argument("--gather must be >= 1, got " + std::to_string(o.gather_rays));
    if (o.direct_samples < 0)
        throw std::invalid_argument("--direct-samples must be >= 0, got " + std::to_string(o.direct_samples));
    if (o.spp < 1) throw std::invalid_argument("--spp must be >= 1, got " + std::to_string(o.spp));
    const int W = camera.width(), H = camera.height();
    const Gatherer g(scene, caster, field);
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

    // Pass 1: the guide sample of every pixel: G-buffer, direct light, indirect light.
    const auto t0 = Clock::now();
    parallel_rows(H, o.threads, [&](int y) {
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            sampling::Rng rng(o.seed, kGuideStreams + p);
            const Vec3 d = camera.direction(x + 0.5, y + 0.5);
            ++camera_rays[y];
            const auto hit = caster.intersect(camera.eye(), d);
            if (!hit.valid() || patches[hit.patch].normal.dot(d) >= 0.0) continue;  // background or back: black
            const Vec3 point = camera.eye() + hit.t * d;
            const auto& patch = patches[hit.patch];
            guide_patch[p] = hit.patch;
            put(r.normal, x, y, patch.normal);
            put(r.depth, x, y, Rgb::Constant(hit.t));
            put(r.position, x, y, point);
            const Rgb direct = scene.material_of(hit.patch).emission +
                               g.direct(hit.patch, point, -d, o.direct_samples, rng, shadow_rays[y]);
            put(r.direct, x, y, direct);
            put(r.indirect, x, y, g.indirect(hit.patch, point, -d, o.gather_rays, rng, gather_rays[y]));
        }
    });
    const auto t1 = Clock::now();

    // Pass 2: filter the incident indirect light.
    const double depth_scale = 1.0 / ((camera.eye() - scene.bounds_center()).norm() + scene.bounds_radius());
    // Positions (for A-Trous) relative to the scene's centre, over the same scale as depth.
    r.indirect_filtered = filter_indirect(r.indirect, r.normal, r.depth, r.position, scene.bounds_center(),
                                          depth_scale, depth_scale, o);
    const auto t2 = Clock::now();

    // Pass 3: compose; further samples look the indirect light up at the guides.
    parallel_rows(H, o.threads, [&](int y) {
        std::vector<Vec3> cand_n;
        std::vector<double> cand_d;
        std::vector<std::pair<int, int>> cand_xy;
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            Rgb sum = Rgb::Zero();
            if (guide_patch[p] >= 0)
                sum = get(r.direct, x, y) + scene.material_of(guide_patch[p]).albedo * get(r.indirect_filtered, x, y);
            if (o.spp > 1) {
                // The stream after the guide's numbers: its own, so the guide pass is unchanged.
                sampling::Rng rng(o.seed, kSampleStreams + p);
                for (int s = 1; s < o.spp; ++s) {
                    const double fx = x + rng.uniform(), fy = y + rng.uniform();
                    const Vec3 d = camera.direction(fx, fy);
                    ++camera_rays[y];
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid() || patches[hit.patch].normal.dot(d) >= 0.0) continue;
                    const auto& patch = patches[hit.patch];
                    const Vec3 point = camera.eye() + hit.t * d;
                    Rgb L = scene.material_of(hit.patch).emission +
                            g.direct(hit.patch, point, -d, o.direct_samples, rng, shadow_rays[y]);
                    // The four guide pixels around the sample point.
                    cand_n.clear();
                    cand_d.clear();
                    cand_xy.clear();
                    const int x0 = static_cast<int>(std::floor(fx - 0.5)), y0 = static_cast<int>(std::floor(fy - 0.5));
                    for (int dy = 0; dy < 2; ++dy)
                        for (int dx = 0; dx < 2; ++dx) {
                            const int cx = std::clamp(x0 + dx, 0, W - 1), cy = std::clamp(y0 + dy, 0, H - 1);
                            if (guide_patch[static_cast<std::size_t>(cy) * W + cx] < 0) continue;
                            const float* n = r.normal.at(cx, cy);
                            cand_n.emplace_back(n[0], n[1], n[2]);
                            cand_d.push_back(r.depth.at(cx, cy)[0]);
                            cand_xy.emplace_back(cx, cy);
                        }
                    const int best = most_similar_guide(patch.normal, hit.t, cand_n, cand_d);
                    if (best >= 0) {
                        const auto [bx, by] = cand_xy[static_cast<std::size_t>(best)];
                        L += scene.material_of(hit.patch).albedo * get(r.indirect_filtered, bx, by);
                        ++lookups[y];
                        if (std::abs(cand_d[static_cast<std::size_t>(best)] - hit.t) > 0.1 * hit.t) ++across[y];
                    }
                    sum += L;
                }
            }
            put(r.image, x, y, sum / o.spp);
        }
    });
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
