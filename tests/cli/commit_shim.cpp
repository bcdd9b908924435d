// A preloaded rename()/unlink() for test_commit.sh: it aims signals at one point of
// an output commit (render::OutputSet::commit) of the program it is loaded into.
//
// The commit's events are counted: each rename of a raybundle temporary (the first is
// the journal's) and the journal's removal at the end. Before the event numbered
// RAYBUNDLE_SHIM_AT (1, 2, ...), the process sends itself the signals listed in
// RAYBUNDLE_SHIM_SIGNALS (numbers, comma-separated: "2,2" is SIGINT twice, "9"
// SIGKILL), 50 ms apart, and goes on.
#include <dlfcn.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <ctime>

namespace {

int g_events;

// A commit's file: its journal, or a staged output (not a writer's ".partial-PID").
bool committed(const char* path) {
    const char* name = std::strrchr(path, '/');
    name = name ? name + 1 : path;
    return std::strncmp(name, ".raybundle-", 11) == 0 && !std::strstr(name, ".partial-");
}


void event() {
    const char* at = std::getenv("RAYBUNDLE_SHIM_AT");
    const char* signals = std::getenv("RAYBUNDLE_SHIM_SIGNALS");
    if (!at || !signals || ++g_events != std::atoi(at)) return;
    // 50 ms after each: one signal is received before the next is sent (two pending
    // are one), and the signals' thread acts while the commit is midway.
    const struct timespec wait = {0, 50 * 1000 * 1000};
    for (const char* s = signals; *s;) {
        kill(getpid(), std::atoi(s));
        nanosleep(&wait, nullptr);
        const char* comma = std::strchr(s, ',');
        if (!comma) break;
        s = comma + 1;
    }
}

}  // namespace

extern "C" {

int rename(const char* from, const char* to) {
    static int (*real)(const char*, const char*);
    if (!real) real = reinterpret_cast<int (*)(const char*, const char*)>(dlsym(RTLD_NEXT, "rename"));
    if (committed(from)) event();
    return real(from, to);
}

int unlink(const char* path) {
    static int (*real)(const char*);
    if (!real) real = reinterpret_cast<int (*)(const char*)>(dlsym(RTLD_NEXT, "unlink"));
    const char* name = std::strrchr(path, '/');
    name = name ? name + 1 : path;
    if (std::strncmp(name, ".raybundle-commit-", 18) == 0 && !std::strstr(name, ".partial")) event();
    return real(path);
}

}  // extern "C"
