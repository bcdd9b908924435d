#include "scenes/machine.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
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

std::string MemoryShare::text() const {
    const std::string has = gigabytes(static_cast<double>(machine));
    if (host.empty()) return "this machine has " + has;
    return "the machine " + host + " has " + has + " for " + std::to_string(sharing) + (sharing == 1 ? " rank" : " ranks");
}

MemoryShare memory_share(const std::vector<std::pair<std::string, std::uint64_t>>& members) {
    std::map<std::string, std::pair<std::uint64_t, int>> machines;  // host: the least memory seen, members
    for (const auto& [host, memory] : members) {
        auto [at, added] = machines.try_emplace(host, memory, 0);
        // A machine whose members read different limits (control groups of their own)
        // counts at the least.
        if (!added && memory > 0 && (at->second.first == 0 || memory < at->second.first)) at->second.first = memory;
        ++at->second.second;
    }
    MemoryShare least;
    for (const auto& [host, seen] : machines) {
        const auto& [memory, sharing] = seen;
        if (memory == 0) continue;  // unknown: no bound from it
        const std::uint64_t bytes = memory / static_cast<std::uint64_t>(sharing);
        if (least.bytes == 0 || bytes < least.bytes) least = {bytes, memory, sharing, host};
    }
    return least;
}

MemoryShare memory_share(const PreparationTeam* team) {
    const std::uint64_t mine = memory_available();
    if (!team || team->size() <= 1) return {mine, mine, 1, ""};
    // Each member's host name, then its memory (8 bytes).
    char name[256] = {};
    if (::gethostname(name, sizeof name - 1) != 0) std::snprintf(name, sizeof name, "rank %d", team->rank());
    std::vector<char> bytes(name, name + std::strlen(name));
    bytes.resize(bytes.size() + sizeof mine);
    std::memcpy(bytes.data() + bytes.size() - sizeof mine, &mine, sizeof mine);
    std::vector<std::pair<std::string, std::uint64_t>> members;
    for (const auto& theirs : team->gather_all(bytes)) {
        if (theirs.size() < sizeof mine) throw std::runtime_error("a rank sent no memory size");
        std::uint64_t memory = 0;
        std::memcpy(&memory, theirs.data() + theirs.size() - sizeof memory, sizeof memory);
        members.emplace_back(std::string(theirs.data(), theirs.size() - sizeof memory), memory);
    }
    return memory_share(members);
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
