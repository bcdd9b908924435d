#include "render/memory.h"

#include "visibility/backend.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
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

std::uint64_t memory_available() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    std::uint64_t total = pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page) : 0;
    auto consider = [&total](const std::string& file) {
        std::ifstream in(file);
        unsigned long long limit = 0;  // "max" (unlimited) does not parse
        if (in >> limit && limit > 0 && (total == 0 || limit < total)) total = limit;
    };
    // The process's control group and every group above it (a limit set by systemd or a
    // batch system sits below the top): "0::/path" for cgroup v2, "N:...memory...:/path"
    // for v1. Paths outside this mount namespace do not exist and are skipped; the top
    // level is read in any case.
    std::ifstream groups("/proc/self/cgroup");
    std::string line;
    while (std::getline(groups, line)) {
        const auto a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
        if (b == std::string::npos) continue;
        const std::string controllers = "," + line.substr(a + 1, b - a - 1) + ",";
        std::string base, file;
        if (controllers == ",,") {
            base = "/sys/fs/cgroup", file = "memory.max";
        } else if (controllers.find(",memory,") != std::string::npos) {
            base = "/sys/fs/cgroup/memory", file = "memory.limit_in_bytes";
        } else {
            continue;
        }
        for (std::filesystem::path p = line.substr(b + 1);; p = p.parent_path()) {
            consider(base + (p.string() == "/" ? "" : p.string()) + "/" + file);
            if (!p.has_relative_path()) break;
        }
    }
    consider("/sys/fs/cgroup/memory.max");
    consider("/sys/fs/cgroup/memory/memory.limit_in_bytes");
    return total;
}

namespace {

std::string gigabytes(double bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
    return text;
}

}  // namespace

void require_memory(const RunConfig& c, const scenes::Scene& scene) {
    const std::uint64_t available = memory_available();
    const MemoryNeed need = memory_need(c, scene);
    if (available == 0 || need.bytes <= static_cast<double>(available)) return;
    const std::string largest = need.pixels >= std::max(need.patches, need.maps)
                                    ? "a smaller image (--width, --height)"
                                : need.patches >= need.maps ? "larger patches (--patch-size)"
                                                            : "a smaller --resolution or another --visibility";
    throw RunError(scene.name + ": " + std::to_string(scene.camera.width) + "x" + std::to_string(scene.camera.height) +
                   " pixels and " + std::to_string(scene.patch_count()) + " patches need about " +
                   gigabytes(need.bytes) + " (pixels " + gigabytes(need.pixels) + ", patches " +
                   gigabytes(need.patches) + ", maps " + gigabytes(need.maps) + "), this machine has " +
                   gigabytes(static_cast<double>(available)) + ": try " + largest);
}

}  // namespace raybundle::render
