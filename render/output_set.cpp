#include "render/output_set.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace raybundle::render {

namespace fs = std::filesystem;

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
    // Its own temporary and the ".partial-PID" write_atomically makes beside it.
    if (tracker_.track) {
        slots_.push_back(tracker_.track(tmp));
        slots_.push_back(tracker_.track(tmp + ".partial-" + pid));
    }
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
    if (tracker_.untrack)
        for (int slot : slots_) tracker_.untrack(slot);
    slots_.clear();
}

void OutputSet::discard() noexcept {
    for (const auto& [tmp, path] : staged_) ::unlink(tmp.c_str());
    staged_.clear();
    untrack();
}

namespace {

void check_output_path(const NamedFile& out) {
    const std::string named = out.name + " " + out.path + ": ";
    struct stat st {};
    if (::stat(out.path.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) throw OutputError(named + "is a directory, not a file");
        if (!S_ISREG(st.st_mode))
            throw OutputError(named + "is a device, a FIFO or a socket, not a file (writing would replace it)");
        if ((st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) == 0) throw OutputError(named + "is read-only");
    } else if (errno != ENOENT) {
        throw OutputError(named + std::strerror(errno));  // e.g. ENOTDIR: a file where a directory should be
    }
    // The nearest directory that exists must let us write (make the rest, or the file).
    std::filesystem::path dir = std::filesystem::absolute(std::filesystem::path(out.path)).parent_path();
    std::error_code ec;
    while (!std::filesystem::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path())
        dir = dir.parent_path();
    if (!std::filesystem::is_directory(dir, ec)) throw OutputError(named + dir.string() + " is not a directory");
    if (::access(dir.c_str(), W_OK) != 0)
        throw OutputError(named + "cannot write in " + dir.string() + " (" + std::strerror(errno) + ")");
}

}  // namespace

void check_outputs(const std::vector<NamedFile>& outputs, const std::vector<NamedFile>& inputs) {
    std::vector<std::string> resolved;
    for (const auto& out : outputs) {
        check_output_path(out);
        resolved.push_back(resolved_path(out.path));
    }
    for (std::size_t a = 0; a < outputs.size(); ++a) {
        for (std::size_t b = a + 1; b < outputs.size(); ++b)
            if (resolved[a] == resolved[b])
                throw OutputError(outputs[a].name + " " + outputs[a].path + " and " + outputs[b].name + " " +
                                  outputs[b].path + " name the same file");
        for (const auto& in : inputs)
            if (resolved[a] == resolved_path(in.path))
                throw OutputError(outputs[a].name + " " + outputs[a].path + ": is " + in.name +
                                  " (it would be overwritten)");
    }
}

}  // namespace raybundle::render
