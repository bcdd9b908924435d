#include "progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace raybundle::apps {

int terminal_width() {
    winsize ws{};
    if (::ioctl(2, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
    if (const char* columns = std::getenv("COLUMNS")) {
        const int n = std::atoi(columns);
        if (n > 0) return n;
    }
    return 80;
}

ProgressBar::ProgressBar(bool quiet) : enabled_(!quiet && ::isatty(2) != 0) {}

ProgressBar::~ProgressBar() { clear(); }

std::string ProgressBar::line(const sampling::Progress& p, int width) {
    const double frac = p.total > 0 ? std::clamp(static_cast<double>(p.done) / p.total, 0.0, 1.0) : 0.0;
    char tail[96];
    if (p.total <= 0)  // how far is unknown: the seconds alone
        std::snprintf(tail, sizeof tail, "  %.1f s", p.seconds);
    else if (frac > 0.0 && frac < 1.0)
        std::snprintf(tail, sizeof tail, " %3d%%  %.1f s, %.1f s left", static_cast<int>(100 * frac), p.seconds,
                      p.seconds * (1.0 - frac) / frac);
    else
        std::snprintf(tail, sizeof tail, " %3d%%  %.1f s", static_cast<int>(100 * frac), p.seconds);
    if (p.round > 0) {
        char round[48];
        if (p.estimate >= 0.0)
            std::snprintf(round, sizeof round, ", round %ld, est. %.2g %%", p.round, 100.0 * p.estimate);
        else
            std::snprintf(round, sizeof round, ", round %ld", p.round);
        std::strncat(tail, round, sizeof tail - std::strlen(tail) - 1);
    }
    std::string label = p.phase;
    const int room = width - 1 - static_cast<int>(label.size()) - static_cast<int>(std::string(tail).size()) - 3;
    std::string out = label;
    if (room >= 10 && p.total > 0) {  // the bar, in what is left
        const int bar = std::min(room, 40), filled = static_cast<int>(frac * bar);
        out += " [" + std::string(static_cast<std::size_t>(filled), '#') + std::string(static_cast<std::size_t>(bar - filled), '.') + "]";
    }
    out += tail;
    if (static_cast<int>(out.size()) > width - 1) out.resize(static_cast<std::size_t>(std::max(0, width - 1)));
    return out;
}

void ProgressBar::operator()(const sampling::Progress& p) {
    if (!enabled_) return;
    const std::lock_guard<std::mutex> guard(lock_);
    // At most ten redraws a second, but every phase's first and last.
    const auto now = std::chrono::steady_clock::now();
    if (phase_ == p.phase && p.done < p.total && now - last_ < std::chrono::milliseconds(100)) return;
    phase_ = p.phase;
    last_ = now;
    const int width = terminal_width();
    const std::string text = line(p, width);
    // \r, the line, then blanks to the width: a shorter line covers a longer one.
    std::fprintf(stderr, "\r%s%*s\r%s", text.c_str(), std::max(0, width - 1 - static_cast<int>(text.size())), "",
                 text.c_str());
    std::fflush(stderr);
    drawn_ = true;
}

void ProgressBar::clear() {
    const std::lock_guard<std::mutex> guard(lock_);
    if (!drawn_) return;
    std::fprintf(stderr, "\r%*s\r", std::max(0, terminal_width() - 1), "");
    std::fflush(stderr);
    drawn_ = false;
}

PreparationProgress::PreparationProgress(ProgressBar& bar) : bar_(bar) {
    if (!bar_.enabled()) return;
    ticker_ = std::thread([this] {
        std::unique_lock<std::mutex> guard(lock_);
        while (!done_) {
            draw();
            wake_.wait_for(guard, std::chrono::milliseconds(200));
        }
    });
}

PreparationProgress::~PreparationProgress() {
    if (ticker_.joinable()) {
        {
            const std::lock_guard<std::mutex> guard(lock_);
            done_ = true;
        }
        wake_.notify_one();
        ticker_.join();
    }
    bar_.clear();
}

void PreparationProgress::step(const char* name) {
    if (!ticker_.joinable()) return;
    const std::lock_guard<std::mutex> guard(lock_);
    label_ = std::string("scene: ") + name;
    draw();  // at once: a short step shows too
}

// Called with lock_ held.
void PreparationProgress::draw() {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    bar_({label_.c_str(), 0, 0, seconds});
}

}  // namespace raybundle::apps
