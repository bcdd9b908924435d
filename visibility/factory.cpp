#include "visibility/backend.h"
#include "visibility/arrangement.h"
#include "visibility/global_zbuffer.h"
#include "visibility/painter.h"
#include "visibility/raycast.h"
#ifdef RAYBUNDLE_HAVE_OPENGL
#include "visibility/zbuffer.h"
#endif

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace raybundle::visibility {

std::vector<std::string> backend_names() {
    return {"painter", "global-zbuffer", "raycast",
#ifdef RAYBUNDLE_HAVE_OPENGL
            "zbuffer",
#endif
#ifdef RAYBUNDLE_HAVE_CGAL
            "arrangement"
#endif
    };
}

std::unique_ptr<Backend> make_backend(const std::string& name, const scenes::Scene& scene,
                                      const BackendOptions& options) {
    if (options.resolution < 0 || options.resolution > 16384)
        throw std::invalid_argument("visibility resolution must be in 1..16384, got " +
                                    std::to_string(options.resolution));
    if (name == "painter") return std::make_unique<PainterBackend>(scene, options);
    if (name == "global-zbuffer") return std::make_unique<GlobalZBufferBackend>(scene, options);
    if (name == "raycast") return std::make_unique<RaycastBackend>(scene, options);
    if (name == "zbuffer") {
#ifdef RAYBUNDLE_HAVE_OPENGL
        if (options.sky)
            throw std::invalid_argument("visibility backend 'zbuffer' does not support a sky (use painter, "
                                        "global-zbuffer, raycast or arrangement)");
        return std::make_unique<ZBufferBackend>(scene, options);
#else
        throw std::invalid_argument("visibility backend 'zbuffer' is not built (configure with RAYBUNDLE_WITH_OPENGL=ON)");
#endif
    }
    if (name == "arrangement") {
#ifdef RAYBUNDLE_HAVE_CGAL
        return std::make_unique<ArrangementBackend>(scene, options.sky);
#else
        throw std::invalid_argument("visibility backend 'arrangement' is not built (configure with RAYBUNDLE_WITH_CGAL=ON)");
#endif
    }
    std::string known;
    for (const auto& n : backend_names()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown visibility backend '" + name + "' (known: " + known + ")");
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
