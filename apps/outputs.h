#pragma once
// The command line's outputs: before any work, every output must be one that can be
// written (and no two may name one file: apps/options.cpp); they are written as a set,
// all new or none touched (render/output_set.h), with their temporaries registered
// with the signal handler (apps/signals.h).
#include "render/output_set.h"

#include <array>
#include <string>

namespace raybundle::apps {

// The images --aov DIR writes, DIR/<name>.exr.
inline constexpr std::array<const char*, 5> kAovNames = {"direct", "indirect", "indirect-filtered", "normal", "depth"};

// Throws UsageError naming `flag` and `path` when the output cannot or must not be
// written: a directory, a device, a FIFO or a socket (`-o /dev/null` would replace the
// node with a file), a read-only file (refused even for root, who could replace it), a
// path below a file, or a directory that cannot be written or made.
void check_output_path(const std::string& path, const std::string& flag);

// An output set whose temporaries a signal that ends the process removes.
render::TemporaryTracker signal_tracker();
using render::resolved_path;

}  // namespace raybundle::apps
