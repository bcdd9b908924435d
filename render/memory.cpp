#include "render/memory.h"

#include "visibility/backend.h"

#include <algorithm>
#include <string>

namespace raybundle::render {

MemoryNeed memory_need(const RunConfig& c, const scenes::Scene& scene) {
    MemoryNeed need;
    const double threads = std::max(1, c.run.threads);
    const bool traced = c.solver.method == "pathtrace";
    need.patches = static_cast<double>(scene.patch_count()) * (traced ? 600.0 : 1400.0 + 250.0 * threads);
    const double per_pixel = traced ? 100.0 : c.gather.gather_rays > 0 ? 340.0 : 230.0;
    need.pixels = per_pixel * static_cast<double>(scene.camera.width) * static_cast<double>(scene.camera.height);
    if (!traced) {
        // The linear basis rasterises with the centre-sorted painter (its own map).
        const std::string& v = c.solver.basis == "linear" ? std::string("painter") : c.solver.visibility;
        const double per_map_pixel = v == "global-zbuffer" ? 58.0 : (v == "painter" || v == "zbuffer") ? 14.0 : 0.0;
        const double side = c.solver.map.resolution > 0 ? c.solver.map.resolution : visibility::default_resolution(scene);
        need.maps = per_map_pixel * side * side * threads;
    }
    need.bytes = 30e6 + 2e6 * threads + need.patches + need.pixels + need.maps;
    return need;
}

using scenes::gigabytes;

void require_memory(const RunConfig& c, const scenes::Scene& scene) {
    const std::uint64_t available = c.memory.bytes;
    const MemoryNeed need = memory_need(c, scene);
    if (available == 0 || need.bytes <= static_cast<double>(available)) return;
    const std::string largest = need.pixels >= std::max(need.patches, need.maps)
                                    ? "a smaller image (--width, --height)"
                                : need.patches >= need.maps ? "larger patches (--patch-size)"
                                                            : "a smaller --resolution or another --visibility";
    throw RunError(scene.name + ": " + std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height) +
                   " pixels and " + std::to_string(scene.patch_count()) + " patches need about " +
                   gigabytes(need.bytes) + " (pixels " + gigabytes(need.pixels) + ", patches " +
                   gigabytes(need.patches) + ", maps " + gigabytes(need.maps) + "), " + c.memory.text() + ": try " + largest);
}

}  // namespace raybundle::render
