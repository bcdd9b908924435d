#include "outputs.h"

#include "cli.h"
#include "signals.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace raybundle::apps {

namespace fs = std::filesystem;

void check_output_path(const std::string& path, const std::string& flag) {
    const std::string named = flag + " " + path + ": ";
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) throw UsageError(named + "is a directory, not a file");
        if (!S_ISREG(st.st_mode))
            throw UsageError(named + "is a device, a FIFO or a socket, not a file (writing would replace it)");
        if ((st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) == 0) throw UsageError(named + "is read-only");
    } else if (errno != ENOENT) {
        throw UsageError(named + std::strerror(errno));  // e.g. ENOTDIR: a file where a directory should be
    }
    // The nearest directory that exists must let us write (make the rest, or the file).
    fs::path dir = fs::absolute(fs::path(path)).parent_path();
    std::error_code ec;
    while (!fs::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path()) dir = dir.parent_path();
    if (!fs::is_directory(dir, ec)) throw UsageError(named + dir.string() + " is not a directory");
    if (::access(dir.c_str(), W_OK) != 0)
        throw UsageError(named + "cannot write in " + dir.string() + " (" + std::strerror(errno) + ")");
}

render::TemporaryTracker signal_tracker() { return {track_temporary, untrack_temporary}; }

}  // namespace raybundle::apps
