#pragma once
// The memory guard: what a run will need, estimated before any work from the scene's
// patches, the image's pixels and the visibility maps, against what the machine has.
// A caller refuses a run that cannot fit at once (the command line: one line, exit 2)
// instead of letting the kernel kill it minutes later. The coefficients were measured on the development
// machine (peak resident memory, /usr/bin/time; README "Memory"):
//
//   about 30 MB + 2 MB per thread + patches x (1.4 KB + 0.25 KB per thread; 0.6 KB
//         path traced)
//       + pixels x (340 B with the final gather, 230 B for the patch image, 100 B
//         path traced)
//       + map pixels x threads x (58 B global z-buffer, 14 B centre-sorted painter and
//         z-buffer; the exact painter, ray casting and arrangements keep no map)
//
// Refitted on 2026-11-29 (the backends of a set sharing the scene's arrays since):
// the Cornell box of 3,722 to 482,224 patches on 1 to 16 threads peaked between 19 %
// below and 4 % above it (docs/benchmarks.md, "Memory per thread").
#include "render/run.h"
#include "scenes/machine.h"

#include <cstdint>

namespace raybundle::render {

struct MemoryNeed {
    double bytes = 0.0;
    double patches = 0.0, pixels = 0.0, maps = 0.0;  // the parts
};
MemoryNeed memory_need(const RunConfig& c, const scenes::Scene& scene);

// The physical memory, or the lowest limit of the process's control group and the
// groups above it where that is lower (bytes; 0 when none can be read).
using scenes::memory_available;

// Throws RunError where the run cannot fit in c.memory (what this process may hold: its
// share of the machine among MPI ranks, scenes/machine.h): one line with the need, its
// parts, what the machine has, and what to make smaller.
void require_memory(const RunConfig& c, const scenes::Scene& scene);


}  // namespace raybundle::render
