#include "progress.h"

#include <cstdio>

#include <unistd.h>

namespace raybundle::apps {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), enabled_(::isatty(2) != 0) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(long done, long total, double seconds) {
    if (!enabled_ || total <= 0) return;
    constexpr int kWidth = 30;
    const double frac = static_cast<double>(done) / total;
    const int filled = static_cast<int>(frac * kWidth);
    char bar[kWidth + 1];
    for (int k = 0; k < kWidth; ++k) bar[k] = k < filled ? '#' : '.';
    bar[kWidth] = '\0';
    const double rate = seconds > 0 ? done / seconds : 0.0;
    const double eta = rate > 0 ? (total - done) / rate : 0.0;
    std::fprintf(stderr, "\r%s [%s] %ld/%ld  %.0f it/s  ETA %.1f s ", label_.c_str(), bar, done, total, rate, eta);
    std::fflush(stderr);
    drawn_ = true;
}

void ProgressBar::finish() {
    if (drawn_) std::fputc('\n', stderr);
    drawn_ = false;
}

}  // namespace raybundle::apps
