#include "render/output_set.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
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
    try {
        write(tmp);
    } catch (const std::exception& e) {
        // Named as the user named it: the temporaries are ours, not theirs.
        std::string what = e.what();
        for (const std::string& hidden : {tmp + ".partial-" + pid, tmp})
            for (std::size_t at = what.find(hidden); at != std::string::npos; at = what.find(hidden, at + path.size()))
                what.replace(at, hidden.size(), path);
        throw std::runtime_error(what);
    }
}

namespace {

// The journal of a commit (see output_set.h): pairs of absolute paths, temporary then
// target, each ended by a zero byte.
constexpr char kJournalPrefix[] = ".raybundle-commit-";

// Writes `path` to disk before going on (a file, or a directory's entries).
void sync_path(const std::string& path, bool directory = false) {
    const int fd = ::open(path.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
    if (fd < 0) return;  // nothing to sync, or a file system that cannot: the renames still go on
    ::fsync(fd);
    ::close(fd);
}

// SIGINT, SIGTERM and SIGHUP held while it lives, then delivered: blocked in this
// thread (a handler of a program without a signal thread), and the tracker's hold()
// (a signal thread that would end the process waits).
class SignalsHeld {
public:
    explicit SignalsHeld(const TemporaryTracker& tracker) : tracker_(tracker) {
        sigset_t set;
        sigemptyset(&set);
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&set, sig);
        ::pthread_sigmask(SIG_BLOCK, &set, &old_);
        if (tracker_.hold) tracker_.hold();
    }
    ~SignalsHeld() {
        if (tracker_.release) tracker_.release();
        ::pthread_sigmask(SIG_SETMASK, &old_, nullptr);
    }
    SignalsHeld(const SignalsHeld&) = delete;
    SignalsHeld& operator=(const SignalsHeld&) = delete;

private:
    const TemporaryTracker& tracker_;
    sigset_t old_;
};

bool process_alive(long pid) { return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM); }

// The PID in a name "<prefix><PID>..." (0 if there is none).
long pid_in(const std::string& name, const std::string& prefix) {
    if (name.compare(0, prefix.size(), prefix) != 0) return 0;
    std::size_t at = prefix.size();
    long pid = 0;
    while (at < name.size() && std::isdigit(static_cast<unsigned char>(name[at])) && pid < 100000000)
        pid = 10 * pid + (name[at++] - '0');
    return pid;
}

// The (temporary, target) pairs of a journal; those of a cut one up to its last
// complete pair.
std::vector<std::pair<std::string, std::string>> journal_pairs(const fs::path& journal) {
    std::ifstream in(journal, std::ios::binary);
    const std::string pairs((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<std::pair<std::string, std::string>> out;
    for (std::size_t at = 0; at < pairs.size();) {
        const std::size_t mid = pairs.find('\0', at), end = mid == std::string::npos ? mid : pairs.find('\0', mid + 1);
        if (end == std::string::npos) break;
        out.emplace_back(pairs.substr(at, mid - at), pairs.substr(mid + 1, end - mid - 1));
        at = end + 1;
    }
    return out;
}

}  // namespace

void OutputSet::commit(const std::function<void(int step)>& after_step) {
    if (staged_.empty()) return;
    // A target that became a directory or a device during the run would stop the
    // renames midway: refused before the first, every output left as it was.
    for (const auto& [tmp, path] : staged_) {
        struct stat st {};
        if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
            throw OutputError(path + ": is " + (S_ISDIR(st.st_mode) ? "a directory" : "a device, a FIFO or a socket") +
                              " now, not a file: no output written");
    }
    // Every temporary complete on disk before any rename publishes it.
    for (const auto& [tmp, path] : staged_) sync_path(tmp);
    // From here to the last rename a signal waits: a second SIGINT cannot cut the set
    // in two; it ends the process after it, every output new.
    const SignalsHeld held(tracker_);
    // The journal, so that a run killed between two renames (SIGKILL, a crash) has its
    // commit completed by the next one that writes there (recover_commits()).
    const fs::path first = fs::absolute(fs::path(staged_.front().second)).parent_path();
    const std::string journal = (first / (kJournalPrefix + std::to_string(::getpid()))).string();
    {
        std::string pairs;
        for (const auto& [tmp, path] : staged_)
            pairs += fs::absolute(tmp).string() + '\0' + fs::absolute(path).string() + '\0';
        const std::string partial = journal + ".partial";
        FILE* f = std::fopen(partial.c_str(), "wb");
        const bool written = f && std::fwrite(pairs.data(), 1, pairs.size(), f) == pairs.size();
        if (f) std::fclose(f);
        sync_path(partial);
        if (!written || std::rename(partial.c_str(), journal.c_str()) != 0) {
            ::unlink(partial.c_str());
            throw std::runtime_error(journal + ": cannot write (" + std::strerror(errno) + ")");
        }
        sync_path(first.string(), true);
    }
    // From here the temporaries belong to the journal: whatever ends the process (a
    // handler on a thread that does not hold the signals, a tracker without hold())
    // must not remove them, or the next run could not complete the set.
    untrack();
    if (after_step) after_step(0);
    for (std::size_t k = 0; k < staged_.size(); ++k) {
        const auto& [tmp, path] = staged_[k];
        if (std::rename(tmp.c_str(), path.c_str()) != 0) {
            // Not one of a set any more: the renames done stay (the journal completes
            // nothing that is gone), the rest is removed with the temporaries.
            const int error = errno;
            ::unlink(journal.c_str());
            throw std::runtime_error(path + ": cannot write (" + std::strerror(error) + ")");
        }
        if (after_step) after_step(static_cast<int>(k) + 1);
    }
    for (const auto& [tmp, path] : staged_) sync_path(fs::absolute(fs::path(path)).parent_path().string(), true);
    ::unlink(journal.c_str());
    staged_.clear();
}

void recover_commits(const std::vector<std::string>& directories) {
    for (const auto& dir : directories) {
        std::error_code ec;
        std::vector<fs::path> journals, partial_journals, temporaries;
        for (const auto& entry : fs::directory_iterator(dir, ec)) {
            const std::string name = entry.path().filename().string();
            if (const long owner = pid_in(name, kJournalPrefix); owner > 0 && !process_alive(owner)) {
                // A journal, or one that was never complete (".partial": no rename began).
                (name.find('.', sizeof kJournalPrefix - 1) == std::string::npos ? journals : partial_journals)
                    .push_back(entry.path());
            } else if (const long pid = pid_in(name, ".raybundle-"); pid > 0 && !process_alive(pid)) {
                temporaries.push_back(entry.path());
            }
        }
        // An interrupted commit is completed: what it had not renamed yet, it renames.
        for (const auto& journal : journals) {
            for (const auto& [tmp, target] : journal_pairs(journal))
                if (fs::exists(tmp, ec)) std::rename(tmp.c_str(), target.c_str());
            fs::remove(journal, ec);
        }
        // One that never began is dropped, with the temporaries it names in other
        // directories (the rest are among this one's).
        for (const auto& journal : partial_journals) {
            for (const auto& [tmp, target] : journal_pairs(journal))
                if (fs::path(tmp).filename().string().rfind(".raybundle-", 0) == 0) fs::remove(tmp, ec);
            fs::remove(journal, ec);
        }
        // Then what dead runs left behind and no commit names: their temporaries.
        for (const auto& tmp : temporaries) fs::remove(tmp, ec);
    }
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
    // Where the file's own directory exists, a file made there and removed at once: some
    // file systems (/proc, /sys) pass the access check and refuse to create files. (Named
    // as a temporary of this process, so a run killed meanwhile leaves nothing another
    // run would not remove.)
    if (dir == full.parent_path()) {
        // (A name taken, by a process of the same number on another host of a shared
        // file system, is tried again with the next.)
        int fd = -1;
        fs::path probe;
        for (int k = 0; k < 64 && fd < 0; ++k) {
            probe = dir / (".raybundle-" + std::to_string(::getpid()) + "-probe-" + std::to_string(k));
            fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
            if (fd < 0 && errno != EEXIST)
                throw OutputError(named + "cannot create a file in " + dir.string() + " (" + std::strerror(errno) + ")");
        }
        if (fd >= 0) {
            ::close(fd);
            ::unlink(probe.c_str());
        }
    }
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
    std::vector<std::string> directories;
    for (const auto& out : outputs) {
        const fs::path dir = fs::absolute(fs::path(out.path)).parent_path();
        if (std::find(directories.begin(), directories.end(), dir.string()) == directories.end())
            directories.push_back(dir.string());
    }
    recover_commits(directories);
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
    for (std::size_t k = 0; k < scene.files.size(); ++k) {
        std::string ext = fs::path(scene.files[k]).extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
        const char* what = scene.files[k] == scene.name ? "the scene file"
                           : ext == ".mtl"               ? "a material library of the scene"
                           : ext == ".png" || ext == ".jpg" || ext == ".jpeg" ? "a texture of the scene"
                           : ext == ".bin"               ? "a buffer of the scene"
                                                         : "a mesh of the scene";
        inputs.push_back({scene.files[k], what});
    }
    return inputs;
}

}  // namespace raybundle::render
