#include "solver/importance.h"

#include "scenes/ray_caster.h"

#include <algorithm>
#include <cmath>

namespace raybundle::solver {

ImportanceWeights importance_weights(const Transport& transport, bool glossy) {
    const scenes::Scene& scene = transport.scene();
    const scenes::Camera& cam = scene.camera;
    const scenes::RayCaster caster(scene);
    const auto& patches = scene.patch_list();
    ImportanceWeights out;
    out.weight.assign(transport.patches(), Rgb::Zero());
    // The pinhole camera's basis (as render/camera.h builds it).
    const Vec3 forward = (cam.target - cam.eye).normalized();
    const Vec3 right = forward.cross(cam.up).normalized();
    const Vec3 up = right.cross(forward);
    const double tan_half = std::tan(0.5 * cam.fov_y * M_PI / 180.0);
    const double aspect = static_cast<double>(cam.width) / cam.height;
    const int gw = std::max(1, std::min(cam.width, aspect >= 1.0 ? 128 : static_cast<int>(128 * aspect)));
    const int gh = std::max(1, std::min(cam.height, aspect >= 1.0 ? static_cast<int>(128 / aspect) : 128));
    long front = 0;
    std::vector<long> hits(transport.patches(), 0);
    for (int y = 0; y < gh; ++y)
        for (int x = 0; x < gw; ++x) {
            const double sx = (2.0 * (x + 0.5) / gw - 1.0) * tan_half * aspect;
            const double sy = (1.0 - 2.0 * (y + 0.5) / gh) * tan_half;
            const Vec3 d = (forward + sx * right + sy * up).normalized();
            const auto hit = caster.intersect(cam.eye, d);
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
