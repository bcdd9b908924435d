#include "visibility/backend.h"
#include "visibility/arrangement.h"
#include "visibility/exact_painter.h"
#include "visibility/global_zbuffer.h"
#include "visibility/painter.h"
#include "visibility/raycast.h"
#ifdef RAYBUNDLE_HAVE_OPENGL
#include "visibility/zbuffer.h"
#endif

#include "scenes/errors.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace raybundle::visibility {

const std::vector<BackendInfo>& backend_infos() {
    static const std::vector<BackendInfo> infos = {
        {"exact-painter", true, true, true, true,
         "painter's order with exact depths per pixel, misordered pixels repaired (default)"},
        {"painter", false, true, true, true, "global painter's algorithm, patches sorted by centre (004 5.1.3; approximate)"},
        {"global-zbuffer", true, true, true, true, "per-pixel fragment lists sorted by exact depth (004 5.1.5)"},
        {"raycast", true, true, true, true, "one Embree ray per pixel, all crossings in order"},
#ifdef RAYBUNDLE_HAVE_OPENGL
        {"zbuffer", true, true, true, false,
         "OpenGL (004 5.1.4): one draw appends every fragment to its pixel's list, compute passes order the lists by "
         "exact depth and count the pairs (OSMesa in software, or EGL on a GPU)"},
#endif
#ifdef RAYBUNDLE_HAVE_CGAL
        {"arrangement", true, false, true, true, "CGAL planar arrangement: exact areas, no pixels (004 5.1.2)"},
#endif
    };
    return infos;
}

std::vector<std::string> backend_names() {
    std::vector<std::string> names;
    for (const auto& info : backend_infos()) names.push_back(info.name);
    return names;
}

const BackendInfo& backend_info(const std::string& name) {
    for (const auto& info : backend_infos())
        if (info.name == name) return info;
    std::string known;
    for (const auto& n : backend_names()) known += (known.empty() ? "" : ", ") + n;
    if (name == "zbuffer" || name == "arrangement")
        throw scenes::OptionError("visibility", "backend '" + name + "' is not built (configure with " +
                                                    (name == "zbuffer" ? "RAYBUNDLE_WITH_OPENGL" : "RAYBUNDLE_WITH_CGAL") +
                                                    "=ON; built: " + known + ")");
    throw scenes::OptionError("visibility", "unknown visibility backend '" + name + "' (known: " + known + ")");
}

std::unique_ptr<Backend> make_backend(const std::string& name, const scenes::Scene& scene,
                                      const BackendOptions& options, std::shared_ptr<const PatchArrays> arrays) {
    const BackendInfo& info = backend_info(name);
    if (options.resolution < 0 || options.resolution > 16384)
        throw scenes::OptionError("resolution", "must be in 1..16384, got " + std::to_string(options.resolution));
    if (options.sky && !info.sky) {
        std::string with_sky;
        for (const auto& i : backend_infos())
            if (i.sky) with_sky += (with_sky.empty() ? "" : ", ") + i.name;
        throw scenes::OptionError("visibility", "backend '" + name + "' does not support a sky (use " + with_sky + ")");
    }
    if (name == "exact-painter") return std::make_unique<ExactPainterBackend>(scene, options, std::move(arrays));
    if (name == "painter") return std::make_unique<PainterBackend>(scene, options, std::move(arrays));
    if (name == "global-zbuffer") return std::make_unique<GlobalZBufferBackend>(scene, options, std::move(arrays));
    if (name == "raycast") return std::make_unique<RaycastBackend>(scene, options, std::move(arrays));
#ifdef RAYBUNDLE_HAVE_OPENGL
    if (name == "zbuffer") return std::make_unique<ZBufferBackend>(scene, options);
#endif
#ifdef RAYBUNDLE_HAVE_CGAL
    if (name == "arrangement") return std::make_unique<ArrangementBackend>(scene, options.sky);
#endif
    throw std::logic_error("backend '" + name + "' is in the table but not in the factory");
}

int default_resolution(const scenes::Scene& scene) {
    std::vector<double> areas;
    areas.reserve(scene.patch_count());
    for (const auto& p : scene.patch_list()) areas.push_back(p.area);
    const std::size_t k = areas.size() / 10;
    std::nth_element(areas.begin(), areas.begin() + static_cast<long>(k), areas.end());
    const double pixel = std::sqrt(areas[k] / 16.0);
    const double r = std::ceil(2.0 * scene.bounds_radius() / pixel);
    return static_cast<int>(std::clamp(r, 64.0, 2048.0));
}

}  // namespace raybundle::visibility
