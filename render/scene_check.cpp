#include "render/scene_check.h"

#include "render/camera.h"
#include "render/gbuffer.h"
#include "sampling/directions.h"
#include "scenes/frame.h"

#include <cmath>
#include <sstream>

namespace raybundle::render {

SceneSummary summarize(const scenes::Scene& scene, const scenes::RayCaster& caster, int threads, long max_pixels) {
    SceneSummary s;
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    s.patches = patches.size();
    s.vertices = pos.size();
    s.lo = s.hi = pos[patches.front().v[0]];
    for (const auto& p : patches)
        for (int v : p.v) s.lo = s.lo.cwiseMin(pos[v]), s.hi = s.hi.cwiseMax(pos[v]);
    s.objects.resize(scene.object_names.size());
    for (std::size_t o = 0; o < s.objects.size(); ++o) s.objects[o].name = scene.object_names[o];

    // What the camera sees: a ray through every pixel centre (of a coarser image with
    // the same field of view when max_pixels asks for fewer).
    scenes::Camera camera = scene.camera;
    const double pixels = static_cast<double>(camera.width) * camera.height;
    if (max_pixels > 0 && pixels > static_cast<double>(max_pixels)) {
        const double scale = std::sqrt(static_cast<double>(max_pixels) / pixels);
        camera.width = std::max(1, static_cast<int>(camera.width * scale));
        camera.height = std::max(1, static_cast<int>(camera.height * scale));
    }
    std::vector<char> seen(patches.size(), 0);
    for (const GSample& g : make_gbuffer(scene, caster, PinholeCamera(camera), threads).samples) {
        if (g.patch < 0) continue;
        const auto i = static_cast<std::size_t>(g.patch);
        auto& object = s.objects[patches[i].object];
        if (g.front) {
            seen[i] = 1;
            ++object.front_pixels;
        } else {
            ++object.back_pixels;
        }
    }

    // Rays from each patch's centroid into its front hemisphere (a fixed 4 x 4 grid of
    // cosine-weighted directions): a front that meets no surface sees nothing but sky.
    const double offset = 1e-6 * scene.bounds_radius();
    for (std::size_t i = 0; i < patches.size(); ++i) {
        const auto& p = patches[i];
        const auto& m = scene.materials[p.material];
        auto& object = s.objects[p.object];
        s.area += p.area;
        object.patches += 1;
        object.area += p.area;
        object.two_sided = object.two_sided || m.two_sided;
        if (m.emissive()) ++s.emissive_patches, s.emissive_area += p.area;
        if (m.glossy()) ++s.glossy_patches;
        if (m.two_sided) ++s.two_sided_patches;
        if (p.normal.dot(scene.camera.eye - p.centroid) > 0.0) ++s.facing_camera;
        if (seen[i]) {
            ++s.seen_by_camera;
            continue;
        }
        if (scene.sky) continue;  // open sky is something to see
        scenes::Vec3 u, v;
        scenes::orthonormal_basis(p.normal, u, v);
        bool meets = false;
        for (int k = 0; k < 16 && !meets; ++k)
            meets = caster.intersect(p.centroid + offset * p.normal,
                                     sampling::cosine_hemisphere((k % 4 + 0.5) / 4, (k / 4 + 0.5) / 4, p.normal, u, v))
                        .valid();
        if (!meets) {
            ++s.unseen;
            object.unseen_area += p.area;
        }
    }
    s.overlaps = scenes::coplanar_overlaps(scene);
    return s;
}

std::vector<std::string> winding_warnings(const SceneSummary& summary) {
    std::vector<std::string> lines;
    const auto percent = [](double part, double whole) { return std::lround(100.0 * part / whole); };
    for (const auto& o : summary.objects) {
        if (o.two_sided) continue;
        std::ostringstream line;
        if (o.back_pixels > o.front_pixels && o.back_pixels >= 16)
            line << o.name << ": the camera sees its back side in " << percent(o.back_pixels, o.back_pixels + o.front_pixels)
                 << " % of the pixels that show it";
        else if (o.area > 0.0 && o.unseen_area > 0.5 * o.area)
            line << o.name << ": the front side of " << percent(o.unseen_area, o.area)
                 << " % of its area faces nothing (no surface, no camera)";
        else
            continue;
        line << " (inverted winding? a two_sided material lights both sides)";
        lines.push_back(line.str());
    }
    return lines;
}

}  // namespace raybundle::render
