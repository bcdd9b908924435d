#pragma once
// The progress bar: one line on stderr, redrawn in place, fitted to the terminal's
// width, for every long phase of a run (diffuse shot, solve, final gather, filter):
//
//   solve [###########.........]  55%  4.1 s, 3.4 s left, round 2, est. 1.4 %
//
// (the round and the image's estimated error so far for a run in rounds,
// render/progressive.h).
// Drawn only when stderr is a terminal and the run is not quiet; cleared at the end.
// Callbacks may come from several threads.
#include "sampling/run.h"

#include <chrono>
#include <mutex>
#include <string>

namespace raybundle::apps {

class ProgressBar {
public:
    explicit ProgressBar(bool quiet);
    ~ProgressBar();
    void operator()(const sampling::Progress& p);
    void clear();

    // The line for a given width (at most width - 1 characters): for tests and drawing.
    static std::string line(const sampling::Progress& p, int width);

private:
    bool enabled_;
    bool drawn_ = false;
    std::string phase_;
    std::chrono::steady_clock::time_point last_{};
    std::mutex lock_;
};

// The terminal's width in columns (stderr; else $COLUMNS; else 80).
int terminal_width();

}  // namespace raybundle::apps
