#pragma once
// What the machine has, for the guards that refuse work it cannot hold before it is
// begun (the scene's preparation: scenes/loader.h; the run: render/memory.h).
#include "scenes/team.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace raybundle::scenes {

// The physical memory, or the lowest limit of the process's control group and the
// groups above it where that is lower (bytes; 0 when none can be read).
std::uint64_t memory_available();

// The memory one process of a run may hold. Alone: memory_available(). As a member of
// a team (MPI ranks, scenes/team.h), whose members each hold the whole scene: each
// machine's memory divided among the members it runs, the least over the machines, so
// that every member decides alike (the patch limit, the run's memory guard).
struct MemoryShare {
    std::uint64_t bytes = 0;    // what one member may hold; 0: unknown (no bound)
    std::uint64_t machine = 0;  // the memory of the machine that gives the least
    int sharing = 1;            // the members it runs
    std::string host;           // its name; empty for a process alone
    // "this machine has 24.0 GB", or "the machine node2 has 24.0 GB for 3 ranks".
    std::string text() const;
};
// Collective on a team of more than one: every member calls it at the same point.
MemoryShare memory_share(const PreparationTeam* team = nullptr);
// The same from each member's host name and memory, in member order.
MemoryShare memory_share(const std::vector<std::pair<std::string, std::uint64_t>>& members);

// Bytes as "12.3 GB" (from 1 GB), "450 MB" or "120 KB".
std::string gigabytes(double bytes);

}  // namespace raybundle::scenes
