#include "signals.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>

namespace raybundle::apps {
namespace {

// The temporaries, in fixed storage, so that the handler reads no memory the main
// thread may be reallocating: a slot's path is written before it is marked used.
constexpr int kSlots = 128;
constexpr std::size_t kMaxPath = 4096;
char g_paths[kSlots][kMaxPath];
std::atomic<bool> g_used[kSlots];

std::atomic<bool> g_stoppable{false};
std::atomic<int> g_stop{0};

void remove_temporaries() {
    for (int i = 0; i < kSlots; ++i)
        if (g_used[i].load()) ::unlink(g_paths[i]);
}

extern "C" void on_signal(int sig) {
    if (g_stoppable.load() && g_stop.load() == 0) {
        g_stop.store(sig);
        static const char line[] =
            "\nraybundle: stopping: the image of the steps done follows (again to abandon the run)\n";
        [[maybe_unused]] const auto n = ::write(STDERR_FILENO, line, sizeof line - 1);
        return;
    }
    remove_temporaries();
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

}  // namespace

void install_signal_handlers() {
    static const bool installed = [] {
        // A signal the process was started ignoring stays ignored (nohup, a background
        // job of a script): no handler for it.
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
            struct sigaction old {};
            if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
            std::signal(sig, on_signal);
        }
        return true;
    }();
    (void)installed;
}

void set_stoppable(bool stoppable) { g_stoppable.store(stoppable); }

int stop_requested() { return g_stop.load(); }

std::string signal_name(int sig) {
    switch (sig) {
        case SIGINT: return "SIGINT";
        case SIGTERM: return "SIGTERM";
        case SIGHUP: return "SIGHUP";
        default: return "signal " + std::to_string(sig);
    }
}

int track_temporary(const std::string& path) {
    install_signal_handlers();
    if (path.size() >= kMaxPath) return -1;
    for (int i = 0; i < kSlots; ++i) {
        if (g_used[i].load()) continue;
        std::memcpy(g_paths[i], path.c_str(), path.size() + 1);
        g_used[i].store(true);
        return i;
    }
    return -1;
}

void untrack_temporary(int slot) {
    if (slot >= 0 && slot < kSlots) g_used[slot].store(false);
}

}  // namespace raybundle::apps
