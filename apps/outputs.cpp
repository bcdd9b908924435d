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

std::string resolved_path(const std::string& path) {
    std::error_code ec;
    const fs::path resolved = fs::weakly_canonical(fs::absolute(fs::path(path)), ec);
    return ec ? fs::absolute(fs::path(path)).lexically_normal().string() : resolved.string();
}

OutputSet::~OutputSet() { discard(); }

void OutputSet::stage(const std::string& path, const std::function<void(const std::string& tmp)>& write) {
    const fs::path target(path);
    if (target.has_parent_path()) fs::create_directories(target.parent_path());
    const std::string pid = std::to_string(::getpid());
    const std::string tmp = (target.parent_path() / (".raybundle-" + pid + "-" + target.filename().string())).string();
    // Its own temporary and the ".partial-PID" render::write_atomically makes beside it.
    slots_.push_back(track_temporary(tmp));
    slots_.push_back(track_temporary(tmp + ".partial-" + pid));
    staged_.emplace_back(tmp, path);
    write(tmp);
}

void OutputSet::commit() {
    for (const auto& [tmp, path] : staged_)
        if (std::rename(tmp.c_str(), path.c_str()) != 0)
            throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
    staged_.clear();
    untrack();
}

void OutputSet::untrack() noexcept {
    for (int slot : slots_) untrack_temporary(slot);
    slots_.clear();
}

void OutputSet::discard() noexcept {
    for (const auto& [tmp, path] : staged_) ::unlink(tmp.c_str());
    staged_.clear();
    untrack();
}

}  // namespace raybundle::apps
