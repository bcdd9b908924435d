#include "render/output_set.h"

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

}  // namespace raybundle::render
