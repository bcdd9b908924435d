#include "render/gbuffer.h"

#include "sampling/rng.h"
#include "sampling/streams.h"
#include "scenes/threads.h"

namespace raybundle::render {

GBuffer make_gbuffer(const scenes::Scene& scene, const scenes::RayCaster& caster, const PinholeCamera& camera,
                     int threads, const PixelPoints& points) {
    GBuffer g;
    g.width = camera.width();
    g.height = camera.height();
    g.samples.resize(static_cast<std::size_t>(g.width) * g.height);  // constructed below, row by row
    const auto& patches = scene.patch_list();
    parallel_rows(g.height, threads, [&](int y) {
        for (int x = 0; x < g.width; ++x) {
            double fx = 0.5, fy = 0.5;
            if (points.drawn) {
                const auto p = static_cast<std::uint64_t>(y) * static_cast<std::uint64_t>(g.width) + x;
                sampling::Rng rng(points.seed, sampling::streams::kGuidePoints(points.pass, p, 32));
                fy = rng.uniform();  // y first: see sampling/rng.h
                fx = rng.uniform();
            }
            const scenes::Vec3 d = camera.direction(x + fx, y + fy);
            const scenes::RayHit hit = caster.intersect(camera.eye(), d);
            GSample* s = ::new (static_cast<void*>(&g.samples[static_cast<std::size_t>(y) * g.width + x])) GSample;
            s->direction = d;
            if (!hit.valid()) continue;
            s->patch = hit.patch;
            s->point = camera.eye() + hit.t * d;
            s->depth = hit.t;
            s->b1 = hit.b1;
            s->b2 = hit.b2;
            s->front = patches[hit.patch].normal.dot(d) < 0.0;
        }
    });
    return g;
}

}  // namespace raybundle::render
