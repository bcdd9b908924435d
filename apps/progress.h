#pragma once
// The progress bar: one line on stderr, redrawn in place, fitted to the terminal's
// width, for every long phase of a run (diffuse shot, solve, final gather, filter):
//
//   solve [###########.........]  55%  4.1 s, 3.4 s left, round 2, est. 1.4 %
//
// (the round and the image's estimated error so far for a run in rounds,
// render/progressive.h). A phase that cannot tell how far it is (total 0) shows its
// seconds alone:
//
//   scene: contacts  4.1 s
//
// Drawn only when stderr is a terminal and the run is not quiet; cleared at the end.
// Callbacks may come from several threads.
#include "sampling/run.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace raybundle::apps {

class ProgressBar {
public:
    explicit ProgressBar(bool quiet);
    ~ProgressBar();
    void operator()(const sampling::Progress& p);
    void clear();
    bool enabled() const { return enabled_; }

    // The line for a given width (at most width - 1 characters): for tests and drawing.
    static std::string line(const sampling::Progress& p, int width);

private:
    bool enabled_;
    bool drawn_ = false;
    std::string phase_;
    std::chrono::steady_clock::time_point last_{};
    std::mutex lock_;
};

// The scene's preparation on a progress bar while it lives: "scene" and the step the
// loader last began (scenes::LoadLimits::on_step), with the seconds so far redrawn
// five times a second by a thread of its own (a step tells only as it begins, and the
// contact search of a million triangles takes seconds). Nothing without a drawn bar.
class PreparationProgress {
public:
    explicit PreparationProgress(ProgressBar& bar);
    ~PreparationProgress();  // stops the thread and clears the line
    PreparationProgress(const PreparationProgress&) = delete;
    PreparationProgress& operator=(const PreparationProgress&) = delete;

    void step(const char* name);  // "reading", "normals", "refining", "contacts", ...

private:
    void draw();

    ProgressBar& bar_;
    const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    std::string label_ = "scene";
    bool done_ = false;
    std::mutex lock_;
    std::condition_variable wake_;
    std::thread ticker_;
};

// The terminal's width in columns (stderr; else $COLUMNS; else 80).
int terminal_width();

}  // namespace raybundle::apps
