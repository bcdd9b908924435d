#pragma once
// The files one run writes, as a set: either every one of them new, or none touched.
// Each is first written to a hidden temporary beside its target, and only when all of
// them have been written are they renamed into place, one rename each (atomic per
// file; between two renames a crash can still leave a mix, for microseconds). A
// failure on the way (an exception) removes the temporaries and leaves the old files
// as they were; so does a signal that ends the process, where the caller's tracker
// registers the temporaries with its handler (the command line: apps/signals.h).
#include "render/image_io.h"

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace raybundle::render {

class OutputSet {
public:
    explicit OutputSet(TemporaryTracker tracker = {}) : tracker_(std::move(tracker)) {}
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
    TemporaryTracker tracker_;
    std::vector<std::pair<std::string, std::string>> staged_;  // temporary, target
    std::vector<int> slots_;                                    // the tracker's
};

// The file `path` names once the directories and links that exist are resolved:
// "./d/x.exr", "d/../d/x.exr" and a link to d/x.exr all give one name.
std::string resolved_path(const std::string& path);

}  // namespace raybundle::render
