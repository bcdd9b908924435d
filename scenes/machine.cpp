#include "scenes/machine.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace raybundle::scenes {

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

std::string gigabytes(double bytes) {
    char text[32];
    if (bytes >= 1e9)
        std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
    else if (bytes >= 1e6)
        std::snprintf(text, sizeof text, "%.0f MB", bytes / 1e6);
    else
        std::snprintf(text, sizeof text, "%.0f KB", bytes / 1e3);
    return text;
}

}  // namespace raybundle::scenes
