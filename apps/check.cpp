// `raybundle check SCENE`: validate a scene and print what it holds, without solving.
#include "cli.h"
#include "render/run_record.h"

#include "render/scene_check.h"
#include "scenes/ray_caster.h"

#include <cstdio>
#include <iostream>

namespace raybundle::apps {

namespace {

std::string vec(const scenes::Vec3& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.4g, %.4g, %.4g)", v.x(), v.y(), v.z());
    return buf;
}

double percent(double part, double whole) { return whole > 0.0 ? 100.0 * part / whole : 0.0; }

}  // namespace

int check_scene(const Command& c) {
    const scenes::Scene scene = load_scene(c);
    const scenes::RayCaster caster(scene);
    const render::SceneSummary s = render::summarize(scene, caster, c.config.run.threads);
    const scenes::Camera& cam = scene.camera;

    std::printf("scene       %s\n", scene.name.c_str());
    std::printf("patches     %zu after refinement (%zu vertices), area %.6g\n", s.patches, s.vertices, s.area);
    if (scene.dropped_degenerate > 0) std::printf("            %zu zero-area triangles dropped\n", scene.dropped_degenerate);
    std::printf("contacts    %s\n", render::contacts_line(scene).c_str());
    std::printf("bounds      %s .. %s\n", vec(s.lo).c_str(), vec(s.hi).c_str());
    std::printf("materials   %zu:", scene.materials.size());
    for (const auto& m : scene.materials)
        std::printf(" %s%s%s%s", m.name.c_str(), m.emissive() ? " (emissive)" : "", m.glossy() ? " (glossy)" : "",
                    m.two_sided ? " (two-sided)" : "");
    std::printf("\n            %zu glossy patches, %zu two-sided\n", s.glossy_patches, s.two_sided_patches);
    std::printf("lights      %zu emissive patches (area %.6g), %zu point lights\n", s.emissive_patches, s.emissive_area,
                scene.point_lights.size());
    std::printf("sky         %s\n", !scene.sky                                            ? "none"
                                    : scene.sky->model == scenes::Sky::Model::constant ? "constant"
                                                                                          : "CIE overcast");
    std::printf("camera      eye %s, target %s, fov_y %g, %d x %d\n", vec(cam.eye).c_str(), vec(cam.target).c_str(),
                cam.fov_y, cam.width, cam.height);
    std::printf("            %zu patches face the camera (%.1f %%), %zu are seen through a pixel centre\n",
                s.facing_camera, percent(s.facing_camera, s.patches), s.seen_by_camera);
    if (scene.sky)
        std::printf("unseen      not counted: with a sky, a front that sees no surface sees the sky\n");
    else
        std::printf("unseen      %zu patches whose front side sees no surface and no camera%s\n", s.unseen,
                    s.unseen > 0 ? " (inverted winding?)" : "");
    std::printf("objects     %zu\n", s.objects.size());
    for (const auto& o : s.objects) {
        std::printf("  %-24s %8zu patches  area %.4g", o.name.c_str(), o.patches, o.area);
        if (o.back_pixels > 0) std::printf("  back seen in %ld pixels", o.back_pixels);
        if (o.unseen_area > 0.0) std::printf("  front unseen: %.0f %%", percent(o.unseen_area, o.area));
        std::printf("\n");
    }
    if (s.overlaps.pairs > 0)
        std::printf("overlaps    %zu pairs of coplanar overlapping patches face the same way (e.g. %u and %u)\n",
                    s.overlaps.pairs, s.overlaps.first, s.overlaps.second);
    for (const auto& w : render::winding_warnings(s)) std::printf("warning     %s\n", w.c_str());
    return 0;
}

}  // namespace raybundle::apps
