#pragma once
// A one-line progress bar on stderr, drawn only when stderr is a terminal.
#include <string>

namespace raybundle::apps {

class ProgressBar {
public:
    explicit ProgressBar(std::string label);
    ~ProgressBar();
    void update(long done, long total, double seconds);
    void finish();

private:
    std::string label_;
    bool enabled_;
    bool drawn_ = false;
};

}  // namespace raybundle::apps
