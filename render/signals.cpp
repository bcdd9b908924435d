#include "render/signals.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <mutex>
#include <thread>
#include <utility>

namespace raybundle::render {
namespace {

// The temporaries, in fixed storage, written before a slot is marked used; the signal
// thread reads them.
constexpr int kSlots = 128;
constexpr std::size_t kMaxPath = 4096;
char g_paths[kSlots][kMaxPath];
std::atomic<bool> g_used[kSlots];

std::atomic<bool> g_stoppable{false};
std::atomic<int> g_stop{0};
std::atomic<bool> g_expected{false};  // expect_signals(): the end is known, a signal is no news
// Held by an OutputSet's commit: a signal that ends the process waits for it.
std::mutex g_commit;

void remove_temporaries() {
    for (int i = 0; i < kSlots; ++i)
        if (g_used[i].load()) ::unlink(g_paths[i]);
}

std::mutex g_reporter_lock;
std::function<bool(int)> g_reporter;

// What a signal does, on the signal thread (not in a handler: it may wait and lock).
void on_signal(int sig) {
    bool hopeless = false;
    {
        const std::lock_guard<std::mutex> guard(g_reporter_lock);
        if (g_reporter) hopeless = g_reporter(sig);
    }
    if (!hopeless && g_stoppable.load() && g_stop.load() == 0) {
        g_stop.store(sig);
        std::cerr << "\nraybundle: stopping: the image of the steps done follows (again to abandon the run)\n";
        return;
    }
    const std::lock_guard<std::mutex> commit(g_commit);  // a commit under way completes first
    remove_temporaries();
    // One closing line: the process ends by the signal, with no message of its own.
    if (!hopeless && !g_expected.load())
        std::cerr << "\nraybundle: " << signal_name(sig) << (g_stop.load() != 0 ? " again" : "")
                  << ": the run abandoned: the files it had not written yet are left as they were\n";
    // Ended by the signal itself (the parent sees 128 + sig): its default action, on
    // this thread, the only one where it is not blocked.
    std::signal(sig, SIG_DFL);
    sigset_t one;
    sigemptyset(&one);
    sigaddset(&one, sig);
    ::pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
    ::raise(sig);
    std::_Exit(128 + sig);  // not reached
}

}  // namespace

void install_signal_handlers() {
    static const bool installed = [] {
        // A signal the process was started ignoring stays ignored (nohup, a background
        // job of a script): not waited for.
        sigset_t set;
        sigemptyset(&set);
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
            struct sigaction old {};
            if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
            sigaddset(&set, sig);
        }
        // Blocked here, before any other thread exists, so in every thread started
        // after (workers, MPI's): only the signal thread receives them.
        ::pthread_sigmask(SIG_BLOCK, &set, nullptr);
        std::thread([set] {
            for (;;) {
                int sig = 0;
                if (::sigwait(&set, &sig) == 0) on_signal(sig);
            }
        }).detach();
        return true;
    }();
    (void)installed;
}

void set_stoppable(bool stoppable) { g_stoppable.store(stoppable); }

void expect_signals() { g_expected.store(true); }

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

void set_signal_reporter(std::function<bool(int)> report) {
    const std::lock_guard<std::mutex> guard(g_reporter_lock);
    g_reporter = std::move(report);
}

void hold_signals() { g_commit.lock(); }
void release_signals() { g_commit.unlock(); }

}  // namespace raybundle::render
