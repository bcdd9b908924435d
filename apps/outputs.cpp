#include "outputs.h"

#include "cli.h"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace raybundle::apps {
namespace {

namespace fs = std::filesystem;

// The temporaries that exist now, for the signal handler: fixed storage, so that the
// handler reads no memory the main thread may be reallocating. Each staged file has
// two (its own and the ".partial-PID" that render::write_atomically makes beside it).
constexpr int kMaxTemporaries = 64;
constexpr std::size_t kMaxPath = 4096;
char g_temporaries[kMaxTemporaries][kMaxPath];
std::atomic<int> g_temporary_count{0};

extern "C" void remove_temporaries_and_die(int sig) {
    const int n = g_temporary_count.load();
    for (int i = 0; i < n; ++i) ::unlink(g_temporaries[i]);
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

void track(const std::string& path) {
    static const bool installed = [] {
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, remove_temporaries_and_die);
        return true;
    }();
    (void)installed;
    const int i = g_temporary_count.load();
    if (i >= kMaxTemporaries || path.size() >= kMaxPath) return;  // not removed on a signal, still on failure
    std::memcpy(g_temporaries[i], path.c_str(), path.size() + 1);
    g_temporary_count.store(i + 1);
}

}  // namespace

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
    track(tmp);
    track(tmp + ".partial-" + pid);
    staged_.emplace_back(tmp, path);
    write(tmp);
}

void OutputSet::commit() {
    for (const auto& [tmp, path] : staged_)
        if (std::rename(tmp.c_str(), path.c_str()) != 0)
            throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
    staged_.clear();
    g_temporary_count.store(0);
}

void OutputSet::discard() noexcept {
    for (const auto& [tmp, path] : staged_) ::unlink(tmp.c_str());
    staged_.clear();
    g_temporary_count.store(0);
}

}  // namespace raybundle::apps
