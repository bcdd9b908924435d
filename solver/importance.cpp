#include "solver/importance.h"

#include "scenes/camera.h"
#include "scenes/ray_caster.h"

#include <algorithm>

namespace raybundle::solver {

ImportanceWeights importance_weights(const Transport& transport, bool glossy) {
    const scenes::Scene& scene = transport.scene();
    const scenes::Camera& cam = scene.camera;
    const scenes::PinholeCamera camera(cam);
    const scenes::RayCaster caster(scene);
    const auto& patches = scene.patch_list();
    ImportanceWeights out;
    out.weight.assign(transport.patches(), Rgb::Zero());
    // A grid of at most 128 x 128 rays over the image, its aspect kept.
    const double aspect = static_cast<double>(cam.width) / cam.height;
    const int gw = std::max(1, std::min(cam.width, aspect >= 1.0 ? 128 : static_cast<int>(128 * aspect)));
    const int gh = std::max(1, std::min(cam.height, aspect >= 1.0 ? static_cast<int>(128 / aspect) : 128));
    long front = 0;
    std::vector<long> hits(transport.patches(), 0);
    for (int y = 0; y < gh; ++y)
        for (int x = 0; x < gw; ++x) {
            const Vec3 d = camera.direction((x + 0.5) * cam.width / gw, (y + 0.5) * cam.height / gh);
            const auto hit = caster.intersect(camera.eye(), d);
            if (!hit.valid() || patches[static_cast<std::size_t>(hit.patch)].normal.dot(d) >= 0.0) continue;
            ++hits[static_cast<std::size_t>(hit.patch)];
            ++front;
        }
    out.rays = gw * gh;
    out.covered = static_cast<double>(front) / out.rays;
    for (std::size_t p = 0; p < hits.size(); ++p) {
        const double c = static_cast<double>(hits[p]) / out.rays;
        out.weight[p] = glossy ? Rgb::Constant(c) : Rgb(c * transport.diffuse_reflectance(p));
    }
    return out;
}

}  // namespace raybundle::solver
