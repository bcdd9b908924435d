#pragma once
// The files one run writes, as a set: either every one of them new, or none touched.
// Each is first written to a hidden temporary beside its target, and only when all of
// them have been written are they renamed into place, one rename each (atomic per
// file; between two renames a crash can still leave a mix, for microseconds). A
// failure on the way, an exception or SIGINT, SIGTERM or SIGHUP removes the
// temporaries and leaves the old files as they were. Before any work, the command
// line checks that every output can be written and that no two name one file.
// (A first signal while the run can stop cleanly does not end it: apps/signals.h.)
#include <array>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace raybundle::apps {

// The images --aov DIR writes, DIR/<name>.exr.
inline constexpr std::array<const char*, 5> kAovNames = {"direct", "indirect", "indirect-filtered", "normal", "depth"};

// Throws UsageError naming `flag` and `path` when the output cannot or must not be
// written: a directory, a device, a FIFO or a socket (`-o /dev/null` would replace the
// node with a file), a read-only file (refused even for root, who could replace it), a
// path below a file, or a directory that cannot be written or made.
void check_output_path(const std::string& path, const std::string& flag);

// The file `path` names once the directories and links that exist are resolved:
// "./d/x.exr", "d/../d/x.exr" and a link to d/x.exr all give one name.
std::string resolved_path(const std::string& path);

class OutputSet {
public:
    OutputSet() = default;
    OutputSet(const OutputSet&) = delete;
    OutputSet& operator=(const OutputSet&) = delete;
    ~OutputSet();  // removes the temporaries of a set not committed

    // Writes `path`'s new content with write(tmp), tmp a hidden file in its directory
    // with the same extension (writers choose the format by it); the directory is made
    // when missing.
    void stage(const std::string& path, const std::function<void(const std::string& tmp)>& write);
    // Renames every staged file into place.
    void commit();

private:
    void discard() noexcept;
    void untrack() noexcept;
    std::vector<std::pair<std::string, std::string>> staged_;  // temporary, target
    std::vector<int> slots_;                                    // apps/signals.h
};

}  // namespace raybundle::apps
