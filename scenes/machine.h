#pragma once
// What the machine has, for the guards that refuse work it cannot hold before it is
// begun (the scene's preparation: scenes/loader.h; the run: render/memory.h).
#include <cstdint>
#include <string>

namespace raybundle::scenes {

// The physical memory, or the lowest limit of the process's control group and the
// groups above it where that is lower (bytes; 0 when none can be read).
std::uint64_t memory_available();

// Bytes as "12.3 GB" (from 1 GB), "450 MB" or "120 KB".
std::string gigabytes(double bytes);

}  // namespace raybundle::scenes
