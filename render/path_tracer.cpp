#include "render/path_tracer.h"

#include "render/direct_light.h"
#include "render/gbuffer.h"
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
        : scene_(scene), caster_(caster), patches_(scene.patch_list()), lighting_(scene, caster) {}

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
            const Vec3 to_eye = -d, n = lighting_.shading_normal(hit.patch, hit.b1, hit.b2, to_eye);
            const Vec3 x = from + hit.t * d;
            scenes::Material scratch;
            const auto& m = scene_.material_at(hit.patch, x, scratch);
            // Light met by the BRDF's direction, weighed against the light point drawn
            // at the previous vertex (balance heuristic).
            if (m.emissive()) {
                const double w = last_pdf > 0.0 ? lighting_.emitter_weight(hit.patch, hit.t, cos_y, last_pdf) : 1.0;
                L += throughput * m.emission * w;
            }
            const Vec3 origin = lighting_.origin(x, patch.normal, to_eye);
            // Next-event estimation: one point of an area light, every point and directional light.
            const DirectLighting::Surface at{m, n, origin, to_eye};
            if (!lighting_.lights().empty())
                lighting_.add_light_point(at, lighting_.draw_light(rng), Lobe::full, throughput, L, rays);
            lighting_.add_punctual_lights(at, throughput, L, rays);
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
    const Buffer<scenes::Patch>& patches_;
    DirectLighting lighting_;
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
