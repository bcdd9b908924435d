#include "render/scene_check.h"

#include "render/camera.h"
#include "render/gbuffer.h"
#include "render/run_record.h"
#include "sampling/directions.h"
#include "scenes/frame.h"
#include "scenes/threads.h"
#include "solver/first_shot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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
    const scenes::Vec3& eye = scene.camera.eye;
    if ((eye.array() < s.lo.array()).any() || (eye.array() > s.hi.array()).any()) {
        const scenes::Vec3 centre = 0.5 * (s.lo + s.hi);
        bool closed = true;
        for (int d = 0; d < 27 && closed; ++d) {
            const scenes::Vec3 w(d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1);
            if (d == 13) continue;  // (0, 0, 0)
            const scenes::RayHit hit = caster.intersect(centre, w.normalized());
            closed = hit.valid() && patches[static_cast<std::size_t>(hit.patch)].normal.dot(w) < 0.0;
        }
        // A room holds the scene: from its centre most of the area is in sight, not
        // behind the shell (an inverted ball on a wide floor is closed around the
        // centre too, but the floor lies outside it). Up to 256 patches, by area.
        if (closed) {
            const std::size_t stride = std::max<std::size_t>(1, (patches.size() + 255) / 256);
            double beyond = 0.0, sampled = 0.0;
            for (std::size_t i = 0; i < patches.size(); i += stride) {
                const scenes::Vec3 d = patches[i].centroid - centre;
                const double dist = d.norm();
                sampled += patches[i].area;
                if (!(dist > 0.0)) continue;
                const scenes::RayHit hit = caster.intersect(centre, d / dist);
                if (hit.valid() && hit.t < 0.98 * dist) beyond += patches[i].area;
            }
            closed = beyond <= 0.5 * sampled;
        }
        s.room_from_outside = closed;
    }
    {
        // Per object, the rays of 26 from the eye that meet its back and its front first.
        std::vector<int> backs(s.objects.size(), 0), fronts(s.objects.size(), 0);
        for (int d = 0; d < 27; ++d) {
            if (d == 13) continue;
            const scenes::Vec3 w = scenes::Vec3(d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1).normalized();
            const scenes::RayHit hit = caster.intersect(eye, w);
            if (!hit.valid()) continue;
            const auto& p = patches[static_cast<std::size_t>(hit.patch)];
            if (scene.materials[p.material].two_sided) continue;
            ++(p.normal.dot(w) > 0.0 ? backs : fronts)[p.object];
        }
        // Inside: two thirds of the directions meet its back, none its front (a block
        // open at its base on a floor lets the rays down through to the floor's front).
        for (std::size_t o = 0; o < s.objects.size(); ++o)
            if (backs[o] >= 18 && fronts[o] == 0) s.camera_inside = static_cast<int>(o);
    }

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

    // A patch no pixel centre met (small, or the image coarse) is seen all the same
    // where its centroid lies in the image, on its front side, and nothing stands
    // between it and the eye.
    const PinholeCamera pinhole(scene.camera);
    const auto in_view = [&](std::size_t i) {
        const auto& p = patches[i];
        const scenes::Vec3 to_eye = scene.camera.eye - p.centroid;
        double x = 0.0, y = 0.0;
        if (!(p.normal.dot(to_eye) > 0.0) || !pinhole.project(p.centroid, x, y)) return false;
        if (x < 0.0 || y < 0.0 || x > pinhole.width() || y > pinhole.height()) return false;
        const double distance = to_eye.norm();
        const scenes::RayHit hit = caster.intersect(scene.camera.eye, -to_eye / distance);
        return hit.valid() && (hit.patch == static_cast<int>(i) || hit.t > distance * (1.0 - 1e-9));
    };

    // Rays from each patch's centroid into its front hemisphere (a fixed 4 x 4 grid of
    // cosine-weighted directions): a front that meets no surface sees nothing but sky.
    const double offset = 1e-6 * scene.bounds_radius();
    // A front within the contact distance of a surface that faces it lies on that
    // surface (scenes/contacts.h's 1e-3 of the bounding radius).
    const double near = 1e-3 * scene.bounds_radius();
    // The object whose surface covers patch i's front (faces it within `near`), or -1;
    // with `backs`, also one whose back it faces there.
    const auto covered = [&](std::size_t i, std::vector<scenes::RayHit>& hits, bool backs = false) {
        const auto& p = patches[i];
        caster.all_hits(p.centroid + near * p.normal, -p.normal, hits, 0.0, 2.0 * near);
        for (const scenes::RayHit& h : hits) {
            const auto& other = patches[static_cast<std::size_t>(h.patch)];
            if (h.patch == static_cast<int>(i)) continue;
            const double facing = other.normal.dot(p.normal);
            // (t below near: in front of it; a coplanar one at near is an overlap, not this)
            if (facing < 0.0 || (backs && facing > 0.0 && h.t < 0.999 * near)) return other.object;
        }
        return -1;
    };
    // What each patch's front is (the rays on the threads), then the sums in patch order.
    enum Front : char { visible, covered_front, unseen_front, behind_front };
    std::vector<char> front(patches.size(), visible);
    std::vector<int> cover(patches.size(), -1);
    std::vector<std::vector<scenes::RayHit>> scratch(static_cast<std::size_t>(std::max(1, threads)));
    parallel_chunks(static_cast<int>(patches.size()), threads, [&](int i0, int i1, int t) {
        for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
            const auto& p = patches[i];
            // A light's front on a surface sends its light nowhere, sky or camera or not.
            if (scene.materials[p.material].emissive() && !seen[i]) {
                cover[i] = covered(i, scratch[static_cast<std::size_t>(t)]);
                if (cover[i] >= 0) {
                    front[i] = covered_front;
                    continue;
                }
                cover[i] = covered(i, scratch[static_cast<std::size_t>(t)], true);
                if (cover[i] >= 0) {
                    front[i] = behind_front;
                    continue;
                }
            }
            // Open sky is something to see, and so is a point or directional light in front.
            const bool lit =
                std::any_of(scene.point_lights.begin(), scene.point_lights.end(),
                            [&](const scenes::PointLight& l) {
                                return (l.intensity > 0.0).any() && p.normal.dot(l.position - p.centroid) > 0.0 &&
                                       l.falloff((p.centroid - l.position).normalized()) > 0.0;
                            }) ||
                std::any_of(scene.directional_lights.begin(), scene.directional_lights.end(),
                            [&](const scenes::DirectionalLight& l) {
                                return (l.irradiance > 0.0).any() && p.normal.dot(l.direction) < 0.0;
                            });
            if (seen[i] || scene.sky || lit || in_view(i)) continue;
            scenes::Vec3 u, v;
            scenes::orthonormal_basis(p.normal, u, v);
            bool meets = false;
            for (int k = 0; k < 16 && !meets; ++k)
                meets = caster.intersect(p.centroid + offset * p.normal,
                                         sampling::cosine_hemisphere((k % 4 + 0.5) / 4, (k / 4 + 0.5) / 4, p.normal, u, v))
                            .valid();
            if (!meets) {
                cover[i] = covered(i, scratch[static_cast<std::size_t>(t)]);
                front[i] = cover[i] >= 0 ? covered_front : unseen_front;
            }
        }
    });
    for (std::size_t i = 0; i < patches.size(); ++i) {
        const auto& p = patches[i];
        const auto& m = scene.materials[p.material];
        auto& object = s.objects[p.object];
        s.area += p.area;
        object.patches += 1;
        object.area += p.area;
        object.two_sided = object.two_sided || m.two_sided;
        if (m.emissive()) ++s.emissive_patches, s.emissive_area += p.area, object.emissive = true;
        if (m.glossy()) ++s.glossy_patches;
        if (m.two_sided) ++s.two_sided_patches;
        if (scene.coloured(i)) ++s.coloured_patches;
        if (p.normal.dot(scene.camera.eye - p.centroid) > 0.0) ++s.facing_camera;
        if (seen[i]) ++s.seen_by_camera;
        if (front[i] == covered_front) {
            ++s.covered;
            object.covered_area += p.area;
            if (object.covered_by < 0) object.covered_by = cover[i];
        } else if (front[i] == behind_front) {
            object.behind_area += p.area;
            if (object.behind < 0) object.behind = cover[i];
        } else if (front[i] == unseen_front) {
            ++s.unseen;
            object.unseen_area += p.area;
        }
    }
    // Each directional light's shadow ray from every patch centroid that faces it; where
    // none arrives, the first shot's points (a pool of sunlight on a large patch may
    // miss every centroid).
    for (const auto& light : scene.directional_lights) {
        std::vector<char> facing(patches.size(), 0), reached(patches.size(), 0);
        parallel_chunks(static_cast<int>(patches.size()), threads, [&](int i0, int i1, int) {
            for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i) {
                const auto& p = patches[i];
                facing[i] = p.normal.dot(light.direction) < 0.0;
                reached[i] = facing[i] && !caster.occluded(p.centroid + offset * p.normal, -light.direction, 0.0,
                                                           std::numeric_limits<double>::infinity());
            }
        });
        SceneSummary::Sun sun;
        sun.facing = static_cast<std::size_t>(std::count(facing.begin(), facing.end(), 1));
        sun.reached = static_cast<std::size_t>(std::count(reached.begin(), reached.end(), 1));
        if (sun.reached == 0 && sun.facing > 0) {
            parallel_chunks(static_cast<int>(patches.size()), threads, [&](int i0, int i1, int) {
                long rays = 0;
                for (auto i = static_cast<std::size_t>(i0); i < static_cast<std::size_t>(i1); ++i)
                    reached[i] = facing[i] && solver::sunlit_share(scene, caster, i, light, rays) > 0.0;
            });
            sun.reached = static_cast<std::size_t>(std::count(reached.begin(), reached.end(), 1));
        }
        s.suns.push_back(sun);
    }
    s.overlaps = scenes::coplanar_overlaps(scene, threads);
    return s;
}

bool has_light(const scenes::Scene& scene) {
    const bool point = std::any_of(scene.point_lights.begin(), scene.point_lights.end(),
                                   [](const scenes::PointLight& l) { return (l.intensity > 0.0).any(); }) ||
                       std::any_of(scene.directional_lights.begin(), scene.directional_lights.end(),
                                   [](const scenes::DirectionalLight& l) { return (l.irradiance > 0.0).any(); });
    const auto& patches = scene.patch_list();
    const bool emission = std::any_of(patches.begin(), patches.end(), [&scene](const scenes::Patch& p) {
        return scene.materials[static_cast<std::size_t>(p.material)].emissive();
    });
    return point || emission || (scene.sky && (scene.sky->radiance > 0.0).any());
}

std::vector<std::string> light_warnings(const scenes::Scene& scene, const SceneSummary& summary) {
    std::vector<std::string> lines;
    for (std::size_t k = 0; k < summary.suns.size() && k < scene.directional_lights.size(); ++k) {
        const auto& light = scene.directional_lights[k];
        const auto& sun = summary.suns[k];
        if (sun.reached > 0 || !(light.irradiance > 0.0).any()) continue;
        const auto& d = light.direction;
        const std::string which = strprintf("%s (travelling along (%.4g, %.4g, %.4g))", light.name.c_str(),
                                            d.x() + 0.0, d.y() + 0.0, d.z() + 0.0);  // (+ 0.0: no "-0")
        if (sun.facing == 0)
            lines.push_back(which + " faces no patch's front: its light goes where no surface faces it (from "
                                    "below the ground? \"direction\" is where the light travels, down for a sun)");
        else
            lines.push_back(which + " reaches no patch: every patch facing it is in shadow (walls all round keep a "
                                    "sun out; open the room towards it, or light it otherwise)");
    }
    return lines;
}

std::string overlap_example(const scenes::Scene& scene, const scenes::CoplanarOverlaps& overlaps) {
    const auto& patches = scene.patch_list();
    const int a = patches[overlaps.first].object, b = patches[overlaps.second].object;
    const auto& names = scene.object_names;
    if (a == b)
        return "patches " + std::to_string(overlaps.first) + " and " + std::to_string(overlaps.second) + " of '" +
               names[static_cast<std::size_t>(a)] + "'";
    return "'" + names[static_cast<std::size_t>(a)] + "' (patch " + std::to_string(overlaps.first) + ") and '" +
           names[static_cast<std::size_t>(b)] + "' (patch " + std::to_string(overlaps.second) + ")";
}

std::vector<std::string> winding_warnings(const SceneSummary& summary) {
    std::vector<std::string> lines;
    const auto percent = [](double part, double whole) { return std::lround(100.0 * part / whole); };
    // A room closed on all sides, framed from outside (an OBJ alone is framed from +z),
    // shows the backs of its walls: the camera's place, not their winding, is wrong.
    const scenes::Vec3 centre = 0.5 * (summary.lo + summary.hi);
    std::ostringstream inside;
    // Its centre, looking at the far wall (-z, as a model alone is framed).
    inside << " (the camera is outside the scene's bounds: a room closed on all sides is seen from outside; "
              "-D camera.eye=["
           << centre.x() << "," << centre.y() << "," << centre.z() << "] -D camera.target=[" << centre.x() << ","
           << centre.y() << "," << summary.lo.z()
           << "] puts it inside. Else: inverted winding? a two_sided material lights both sides)";
    for (std::size_t k = 0; k < summary.objects.size(); ++k) {
        const auto& o = summary.objects[k];
        if (summary.camera_inside == static_cast<int>(k)) {
            lines.push_back(o.name + ": the camera's eye is inside it: all it shows from there is its back side "
                                     "(move camera.eye out of it; or, if the camera is meant to be there, its winding is "
                                     "inverted)");
            continue;
        }
        if (o.emissive && !o.two_sided && o.area > 0.0 && o.covered_area > 0.5 * o.area) {  // (a two-sided light's other side shines)
            const std::string other = o.covered_by >= 0 ? "'" + summary.objects[static_cast<std::size_t>(o.covered_by)].name + "'"
                                                        : "another surface";
            lines.push_back(o.name + ": the emitting front of " + std::to_string(percent(o.covered_area, o.area)) +
                            " % of its area lies against " + other +
                            ", so its light cannot leave (inverted winding? a light under a ceiling faces down)");
            continue;
        }
        if (o.emissive && !o.two_sided && o.area > 0.0 && o.behind_area > 0.5 * o.area) {
            lines.push_back(o.name + ": the emitting front of " + std::to_string(percent(o.behind_area, o.area)) +
                            " % of its area lies just behind '" + summary.objects[static_cast<std::size_t>(o.behind)].name +
                            "', facing its back, which lets no light through (place the light on the surface's front side)");
            continue;
        }
        if (o.two_sided) continue;
        std::ostringstream line;
        if (o.back_pixels > o.front_pixels && o.back_pixels >= 16) {
            line << o.name << ": the camera sees its back side in " << percent(o.back_pixels, o.back_pixels + o.front_pixels)
                 << " % of the pixels that show it";
            if (summary.room_from_outside) {
                lines.push_back(line.str() + inside.str());
                continue;
            }
        }
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

namespace {

std::string vec3(const scenes::Vec3& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.4g, %.4g, %.4g)", v.x() + 0.0, v.y() + 0.0, v.z() + 0.0);  // (no "-0")
    return buf;
}

double percent(double part, double whole) { return whole > 0.0 ? 100.0 * part / whole : 0.0; }

}  // namespace

std::string describe(const scenes::Scene& scene, const SceneSummary& s) {
    const scenes::Camera& cam = scene.camera;
    std::string out;
    auto print = [&out](const char* format, auto... values) { out += strprintf(format, values...); };

    print("scene       %s\n", scene.name.c_str());
    print("patches     %zu after refinement (%zu vertices), area %.6g\n", s.patches, s.vertices, s.area);
    if (!scene.refinement.empty()) print("            %s\n", scene.refinement.c_str());
    if (scene.dropped_degenerate > 0) print("            %s\n", scene.dropped_summary().c_str());
    if (scene.welded_vertices > 0)
        print("            %zu mesh vertices at the place of another welded to it\n", scene.welded_vertices);
    print("contacts    %s\n", contacts_line(scene).c_str());
    print("bounds      %s .. %s\n", vec3(s.lo).c_str(), vec3(s.hi).c_str());
    print("materials   %zu:", scene.materials.size());
    for (std::size_t k = 0; k < scene.materials.size(); ++k) {
        const auto& m = scene.materials[k];
        // Comma-separated, a name with a space or a comma quoted: imported names have them.
        const bool quote = m.name.find_first_of(" ,") != std::string::npos;
        print("%s %s%s%s%s%s%s%s", k > 0 ? "," : "", quote ? "\"" : "", m.name.c_str(), quote ? "\"" : "",
              m.emissive() ? " (emissive)" : "", m.glossy() ? " (glossy)" : "", m.two_sided ? " (two-sided)" : "",
              m.texture ? (" (texture " + m.texture->shown + ")").c_str() : "");
    }
    print("\n            %zu glossy patches, %zu two-sided", s.glossy_patches, s.two_sided_patches);
    if (s.coloured_patches > 0) print(", %zu with vertex colours (times the albedo)", s.coloured_patches);
    out += "\n";
    const auto spots = std::count_if(scene.point_lights.begin(), scene.point_lights.end(),
                                     [](const scenes::PointLight& l) { return l.spot(); });
    print("lights      %zu emissive patches (area %.6g), %zu point lights%s", s.emissive_patches, s.emissive_area,
          scene.point_lights.size(), spots > 0 ? (" (" + std::to_string(spots) + (spots == 1 ? " spot)" : " spots)")).c_str() : "");
    if (!scene.directional_lights.empty()) print(", %zu directional", scene.directional_lights.size());
    out += "\n";
    for (std::size_t k = 0; k < scene.directional_lights.size() && k < s.suns.size(); ++k) {
        const auto& l = scene.directional_lights[k];
        print("            %s: along %s, irradiance %s, reaches %zu of %zu patches\n", l.name.c_str(),
              vec3(l.direction).c_str(), vec3(l.irradiance.matrix()).c_str(), s.suns[k].reached, s.patches);
    }
    print("sky         %s\n", !scene.sky                                            ? "none"
                                    : scene.sky->model == scenes::Sky::Model::constant ? "constant"
                                                                                          : "CIE overcast");
    print("camera      eye %s, target %s, up %s, fov_y %g, %d x %d\n", vec3(cam.eye).c_str(),
          vec3(cam.target).c_str(), vec3(cam.up).c_str(), cam.fov_y, cam.width, cam.height);
    print("            %zu patches face the camera (%.1f %%), %zu are seen through a pixel centre\n",
                s.facing_camera, percent(s.facing_camera, s.patches), s.seen_by_camera);
    if (scene.sky)
        print("unseen      not counted: with a sky, a front that sees no surface sees the sky\n");
    else
        print("unseen      %zu patches whose front side sees no surface and no camera%s\n", s.unseen,
                    s.unseen > 0 ? " (inverted winding?)" : "");
    if (s.covered > 0)
        print("covered     %zu patches lie face to face on another surface (a box's bottom on a floor): hidden,"
              " not inverted\n", s.covered);
    print("objects     %zu\n", s.objects.size());
    int name_width = 24;  // the column as wide as the longest name
    for (const auto& o : s.objects) name_width = std::max(name_width, static_cast<int>(o.name.size()));
    for (const auto& o : s.objects) {
        print("  %-*s %8zu patches  area %.4g", name_width, o.name.c_str(), o.patches, o.area);
        if (o.back_pixels > 0) print("  back seen in %ld pixels", o.back_pixels);
        if (o.unseen_area > 0.0) print("  front unseen: %.0f %%", percent(o.unseen_area, o.area));
        if (o.covered_area > 0.0) print("  front covered: %.0f %%", percent(o.covered_area, o.area));
        out += "\n";
    }
    if (s.overlaps.pairs > 0)
        print("overlaps    %zu pairs of coplanar overlapping patches face the same way (e.g. %s)\n", s.overlaps.pairs,
              overlap_example(scene, s.overlaps).c_str());
    // Each warning once, as the solve passes them on (a mesh placed twice gives its own twice).
    std::vector<std::pair<std::string, int>> distinct;
    for (const auto& w : scene.warnings) {
        const auto it = std::find_if(distinct.begin(), distinct.end(), [&](const auto& d) { return d.first == w; });
        if (it != distinct.end()) ++it->second;
        else distinct.emplace_back(w, 1);
    }
    for (const auto& [w, times] : distinct)
        print("warning     %s%s\n", w.c_str(), times > 1 ? (" (" + std::to_string(times) + " times)").c_str() : "");
    for (const auto& w : winding_warnings(s)) print("warning     %s\n", w.c_str());
    for (const auto& w : light_warnings(scene, s)) print("warning     %s\n", w.c_str());
    if (!has_light(scene)) print("warning     %s\n", kNoLight);
    return out;
}

}  // namespace raybundle::render
