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

// What a temporary adds to an output's name: ".raybundle-PID-" before it, ".partial-PID"
// after it (PIDs of up to 7 digits).
constexpr std::size_t kTemporaryOverhead = 40;

void check_output_path(const NamedFile& out) {
    const std::string named = out.name + " " + out.path + ": ";
    struct stat st {};
    if (::stat(out.path.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) throw OutputError(named + "is a directory, not a file");
        if (!S_ISREG(st.st_mode))
            throw OutputError(named + "is a device, a FIFO or a socket, not a file (writing would replace it)");
        if ((st.st_mode & (S_IWUSR | S_IWGRP | S_IWOTH)) == 0) throw OutputError(named + "is read-only");
    } else if (errno != ENOENT && errno != ENAMETOOLONG) {
        throw OutputError(named + std::strerror(errno));  // e.g. ENOTDIR: a file where a directory should be
    }
    // The nearest directory that exists must let us write (make the rest, or the file).
    const std::filesystem::path full = std::filesystem::absolute(std::filesystem::path(out.path));
    std::filesystem::path dir = full.parent_path();
    std::error_code ec;
    while (!std::filesystem::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path())
        dir = dir.parent_path();
    if (!std::filesystem::is_directory(dir, ec)) throw OutputError(named + dir.string() + " is not a directory");
    if (::access(dir.c_str(), W_OK) != 0)
        throw OutputError(named + "cannot write in " + dir.string() + " (" + std::strerror(errno) + ")");
    // Names the file system takes, with the temporary's additions: checked now, not
    // when the outputs are written after the whole run.
    const long name_max = ::pathconf(dir.c_str(), _PC_NAME_MAX), path_max = ::pathconf(dir.c_str(), _PC_PATH_MAX);
    const std::size_t names = name_max > 0 ? static_cast<std::size_t>(name_max) : 255;
    const std::size_t paths = path_max > 0 ? static_cast<std::size_t>(path_max) : 4096;
    for (const auto& part : full)
        if (part.string().size() > names - (part == full.filename() ? kTemporaryOverhead : 0))
            throw OutputError(named + "a name of " + std::to_string(part.string().size()) + " bytes (" +
                              part.string().substr(0, 16) + "...): at most " +
                              std::to_string(names - (part == full.filename() ? kTemporaryOverhead : 0)) +
                              " here" + (part == full.filename() ? ", with the temporary's additions" : ""));
    if (full.string().size() + kTemporaryOverhead >= paths)
        throw OutputError(named + "a path of " + std::to_string(full.string().size()) + " bytes: at most " +
                          std::to_string(paths - kTemporaryOverhead - 1) + " here, with the temporary's additions");
}

// Whether two paths name one file: the same device and inode where both exist (hard
// links too), else the same resolved name.
bool same_file(const std::string& a, const std::string& b) {
    struct stat sa {}, sb {};
    if (::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    return resolved_path(a) == resolved_path(b);
}

}  // namespace

void check_outputs(const std::vector<NamedFile>& outputs, const std::vector<NamedFile>& inputs) {
    for (const auto& out : outputs) check_output_path(out);
    for (std::size_t a = 0; a < outputs.size(); ++a) {
        for (std::size_t b = a + 1; b < outputs.size(); ++b)
            if (same_file(outputs[a].path, outputs[b].path))
                throw OutputError(outputs[a].name + " " + outputs[a].path + " and " + outputs[b].name + " " +
                                  outputs[b].path + " name the same file");
        for (const auto& in : inputs)
            if (same_file(outputs[a].path, in.path))
                throw OutputError(outputs[a].name + " " + outputs[a].path + ": is " + in.name +
                                  " (it would be overwritten)");
    }
}

std::vector<NamedFile> with_scene_files(std::vector<NamedFile> inputs, const scenes::Scene& scene) {
    for (std::size_t k = 0; k < scene.files.size(); ++k)
        inputs.push_back({scene.files[k], scene.files[k] == scene.name ? "the scene file" : "a mesh of the scene"});
    return inputs;
}

}  // namespace raybundle::render
