#pragma once
// A process's signals around run(): SIGINT, SIGTERM and SIGHUP (the command line's,
// apps/solve.cpp, or any program's that wants the same behaviour).
//
// While the run can stop cleanly (set_stoppable(true): `solve` from its solve on), the
// first such signal asks it to stop: stop_requested() returns it from then on, and a
// line on stderr says what happens (the solve stops after its current steps, the
// image is made from the steps done, the outputs are written, marked partial; exit
// 128 + the signal: 130, 143, 129). A second signal, or the first one while the run
// cannot stop cleanly (loading, path tracing), removes the temporaries registered
// here and ends the process by the signal, leaving every output not yet written as it
// was before, with one line on stderr saying so ("raybundle: SIGINT again: the run
// abandoned: ..."), unless expect_signals() said that a signal is no news.
//
// A signal the process was started ignoring (nohup: SIGHUP) stays ignored.
//
// The signals are blocked in every thread and received by one thread of their own
// (sigwait), so no worker is ever interrupted by them, and what they do may wait: a
// signal that ends the process waits for a commit of the outputs under way
// (hold_signals() .. release_signals(), render::OutputSet::commit).
//
// Call order: install_signal_handlers() first in main, before any other thread starts
// (MPI's, the workers'), so that they all inherit the blocked signals; track a
// temporary before creating it, untrack it once renamed or removed.
#include "render/image_io.h"

#include <functional>
#include <string>

namespace raybundle::render {

void install_signal_handlers();
void set_stoppable(bool stoppable);
// From now on a signal that ends the process says nothing (render/ranks.cpp: once the
// ranks know how the run ends, mpirun may signal rank 0 for the others' exits).
void expect_signals();
// 0, or the first signal received while stoppable.
int stop_requested();
// "SIGINT", "SIGTERM", "SIGHUP" (or "signal N").
std::string signal_name(int sig);

// A file to remove if a signal ends the process: a slot for untrack_temporary(), or -1
// when all slots are taken (the file is then removed on failures only).
int track_temporary(const std::string& path);
void untrack_temporary(int slot);
// Called on the signal thread when a signal arrives, before it acts; true: the run
// cannot go on (the signal ends the process at once, as a second one does).
// render/ranks.cpp: rank 0 names the ranks on its host that died, whose death made
// mpirun signal it.
void set_signal_reporter(std::function<bool(int sig)> report);
// While held, a signal that would end the process waits.
void hold_signals();
void release_signals();
// The four above as a tracker for render::OutputSet and render::run's checkpoints.
inline TemporaryTracker signal_tracker() {
    return {track_temporary, untrack_temporary, hold_signals, release_signals};
}

}  // namespace raybundle::render
