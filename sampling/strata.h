#pragma once
// n samples of the unit square on a jittered grid: cols x rows cells, cols * rows = n,
// as square as n's divisors allow (16: 4 x 4, 8: 2 x 4, 7: 1 x 7), one sample in each.
// Halves of a budget (render/progressive.h) keep a grid this way where a square one
// would not exist.
#include <utility>

namespace raybundle::sampling {

class Strata {
public:
    explicit Strata(int n) : cols_(1), rows_(n > 0 ? n : 1) {
        for (int c = 1; c * c <= n; ++c)
            if (n % c == 0) cols_ = c, rows_ = n / c;
    }
    // Sample k's point: (u1, u2) in [0, 1)^2 moved into cell k.
    std::pair<double, double> point(int k, double u1, double u2) const {
        return {((k % cols_) + u1) / cols_, ((k / cols_) % rows_ + u2) / rows_};
    }

private:
    int cols_, rows_;
};

}  // namespace raybundle::sampling
