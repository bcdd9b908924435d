#pragma once
// The files one run writes, as a set: either every one of them new, or none touched.
// Each is first written to a hidden temporary beside its target, and only when all of
// them have been written are they renamed into place (commit()), with signals held and
// a journal that lets the next run complete a commit a killed process left midway. A
// failure before the commit (an exception) removes the temporaries and leaves the old
// files as they were; so does a signal that ends the process, where the caller's
// tracker registers the temporaries with its handler (the command line: render/signals.h).
#include "render/image_io.h"
#include "scenes/scene.h"

#include <functional>
#include <stdexcept>
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
    // when missing. A failure of write() is rethrown (std::runtime_error) with the
    // temporaries' names in its message replaced by `path`.
    void stage(const std::string& path, const std::function<void(const std::string& tmp)>& write);
    // Makes the staged files the outputs, all of them: a target that is no longer a file
    // or absent (a directory made there during the run) is refused first (OutputError,
    // nothing renamed); each is synced to disk, then, with
    // SIGINT, SIGTERM and SIGHUP held (a signal waits until the set is complete), a
    // journal of the renames written beside the first (the temporaries then leave the
    // tracker: they belong to the journal), the renames, and the journal removed. A process killed between two renames (SIGKILL, a crash) leaves the
    // journal, and the next check_outputs() in that directory completes the commit.
    // `after_step` (tests) is called after step k: 0 the journal, k >= 1 the k-th rename.
    void commit(const std::function<void(int step)>& after_step = {});

private:
    void discard() noexcept;
    void untrack() noexcept;
    TemporaryTracker tracker_;
    std::vector<std::pair<std::string, std::string>> staged_;  // temporary, target
    std::vector<int> slots_;                                    // the tracker's
};

// An output that must not be written, or outputs that clash: the message names the
// file and what asked for it.
struct OutputError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A file a run writes or reads, and what names it for the user (a flag, "the scene file").
struct NamedFile {
    std::string path, name;
};

// Before any work (after recover_commits() in the outputs' directories): throws
// OutputError where an output cannot or must not be written
// (a directory, a device, a FIFO or a socket, which writing would replace with a file;
// a read-only file, refused even for root, who could replace it; a path below a file;
// a directory that cannot be written or made), where two outputs name one file, or
// where an output is one of the inputs (it would be overwritten), or where a name, or
// the whole path, is longer than the file system takes with what a temporary adds to
// it. Files are compared by device and inode where both exist (a hard link is the file
// it links), else by their resolved names (./d/x.exr is d/x.exr).
void check_outputs(const std::vector<NamedFile>& outputs, const std::vector<NamedFile>& inputs);
// `inputs` and the files the scene was read from (Scene::files: its meshes).
std::vector<NamedFile> with_scene_files(std::vector<NamedFile> inputs, const scenes::Scene& scene);

// In each directory: completes the commits that runs killed midway left (their journal,
// named by a process that is no longer running), drops those killed before their first
// rename (a ".partial" journal, and the temporaries it names wherever they are), then
// removes the temporaries such runs left behind. check_outputs() calls it for the
// outputs' directories.
void recover_commits(const std::vector<std::string>& directories);

// The file `path` names once the directories and links that exist are resolved:
// "./d/x.exr", "d/../d/x.exr" and a link to d/x.exr all give one name.
std::string resolved_path(const std::string& path);

}  // namespace raybundle::render
