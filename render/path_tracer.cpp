#include "render/path_tracer.h"

#include "render/gbuffer.h"
#include "render/lights.h"
#include "sampling/rng.h"
#include "sampling/strata.h"
#include "sampling/streams.h"
#include "scenes/brdf.h"
#include "scenes/errors.h"
#include "scenes/threads.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;

namespace {

constexpr int kMaxVertices = 10000;
constexpr int kRouletteFrom = 3;  // vertices before Russian roulette starts

class PathTracer {
public:
    PathTracer(const scenes::Scene& scene, const scenes::RayCaster& caster)
        : scene_(scene), caster_(caster), patches_(scene.patch_list()), lights_(scene),
          offset_(1e-5 * scene.bounds_radius()) {}

    // Radiance arriving at `eye` along -d (the path's first ray leaves eye along d).
    Rgb radiance(Vec3 from, Vec3 d, sampling::Rng& rng, long& rays) const {
        Rgb L = Rgb::Zero(), throughput = Rgb::Ones();
        double last_pdf = 0.0;  // the BRDF density of the direction d (0: a camera ray)
        for (int vertex = 0; vertex < kMaxVertices; ++vertex) {
            ++rays;
            const auto hit = caster_.intersect(from, d);
            if (!hit.valid()) {
                if (scene_.sky) L += throughput * scene_.sky->arriving_along(-d);  // light travels along -d
                break;
            }
            const auto& patch = patches_[hit.patch];
            const double cos_y = -patch.normal.dot(d);
            if (cos_y <= 0.0) break;  // the back of a one-sided patch: black
            // Shading with the interpolated normal, unless the eye is below its horizon.
            Vec3 n = scene_.shading_normal(hit.patch, hit.b1, hit.b2);
            if (n.dot(d) >= 0.0) n = patch.normal;
            const auto& m = scene_.material_of(hit.patch);
            const Vec3 x = from + hit.t * d, to_eye = -d;
            if (m.emissive()) {
                double w = 1.0;
                if (last_pdf > 0.0) {
                    const double pl = lights_.pdf_solid_angle(hit.patch, hit.t, cos_y);
                    w = last_pdf / (last_pdf + pl);
                }
                L += throughput * m.emission * w;
            }
            const Vec3 origin = x + offset_ * (patch.normal + to_eye);
            // Next-event estimation: one point of an area light, every point light.
            if (!lights_.empty()) {
                const auto s = lights_.sample(rng.uniform(), rng.uniform(), rng.uniform());
                const Vec3 dl = s.point - origin;
                const double r = dl.norm();
                const Vec3 w = dl / r;
                const double cos_x = n.dot(w), cos_l = -patches_[s.patch].normal.dot(w);
                if (r > 0.0 && cos_x > 0.0 && cos_l > 0.0) {
                    ++rays;
                    if (!caster_.intersect(origin, w, 0.0, r * (1.0 - 1e-5)).valid()) {
                        const double pl = lights_.pdf_solid_angle(s.patch, r, cos_l);
                        const double pb = scenes::brdf_pdf(m, n, to_eye, w);
                        L += throughput * scenes::brdf(m, n, -w, to_eye) * scene_.material_of(s.patch).emission *
                             (cos_x / (pl + pb));
                    }
                }
            }
            for (const auto& light : scene_.point_lights) {
                const Vec3 dl = light.position - origin;
                const double r = dl.norm();
                if (r <= 0.0) continue;
                const Vec3 w = dl / r;
                const double cos_x = n.dot(w);
                if (cos_x <= 0.0) continue;
                ++rays;
                if (caster_.intersect(origin, w, 0.0, r * (1.0 - 1e-5)).valid()) continue;
                L += throughput * scenes::brdf(m, n, -w, to_eye) * light.intensity * (cos_x / (r * r));
            }
            // Continue along a direction drawn from the BRDF.
            const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
            const auto s = scenes::sample_brdf(m, n, to_eye, u1, u2, u3);
            const double cos_x = n.dot(s.direction);
            if (s.pdf <= 0.0 || cos_x <= 0.0) break;
            throughput *= scenes::brdf(m, n, -s.direction, to_eye) * (cos_x / s.pdf);
            if (vertex >= kRouletteFrom) {
                const double q = std::min(0.95, throughput.maxCoeff());
                if (!(q > 0.0) || rng.uniform() >= q) break;
                throughput /= q;
            }
            if (!(throughput.maxCoeff() > 0.0)) break;
            from = origin;
            d = s.direction;
            last_pdf = s.pdf;
        }
        return L;
    }

private:
    const scenes::Scene& scene_;
    const scenes::RayCaster& caster_;
    const std::vector<scenes::Patch>& patches_;
    AreaLights lights_;
    double offset_;
};

}  // namespace

PathTraceResult path_trace(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                           const PathTraceOptions& o, const sampling::RunOptions& run) {
    if (o.spp < 1) throw scenes::OptionError("spp", "must be >= 1, got " + std::to_string(o.spp));
    const auto t0 = std::chrono::steady_clock::now();
    const int W = camera.width(), H = camera.height();
    PathTraceResult r;
    r.image = Image(W, H);
    const PathTracer tracer(scene, caster);
    const sampling::Strata strata(o.spp);
    std::vector<long> rays(H, 0);
    long rows_done = 0;
    std::mutex progress_lock;
    parallel_rows(H, run.threads, [&](int y) {
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            sampling::Rng rng(run.seed, sampling::streams::kPathPixels(o.pass, p, 32));
            Rgb sum = Rgb::Zero();
            for (int s = 0; s < o.spp; ++s) {
                const double r1 = rng.uniform(), r2 = rng.uniform();
                const auto [fx, fy] = strata.point(s, r1, r2);
                sum += tracer.radiance(camera.eye(), camera.direction(x + fx, y + fy), rng, rays[y]);
            }
            float* out = r.image.at(x, y);
            for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(sum[k] / o.spp);
        }
        if (run.progress) {
            const std::lock_guard<std::mutex> lock(progress_lock);
            run.report("path trace", ++rows_done, H,
                       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
    });
    for (long n : rays) r.rays += n;
    r.paths = static_cast<long>(W) * H * o.spp;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace raybundle::render
