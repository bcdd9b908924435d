#include "visibility/parallel.h"

#include "scenes/threads.h"

#include <algorithm>

namespace raybundle::visibility {

BackendSet::BackendSet(const std::string& name, const scenes::Scene& scene, const BackendOptions& options,
                       int threads) {
    const int n = backend_info(name).side_by_side ? std::max(1, threads) : 1;
    for (int k = 0; k < n; ++k) {
        owned_.push_back(make_backend(name, scene, options));
        all_.push_back(owned_.back().get());
    }
}

BackendSet::BackendSet(Backend& single) { all_.push_back(&single); }

void BackendSet::transfer_batch(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                                std::vector<GeometryMatrix>& out) {
    const std::size_t n = directions.size();
    out.resize(n);
    const std::size_t T = std::min(all_.size(), n);
    if (T <= 1) {
        for (std::size_t k = 0; k < n; ++k) all_[0]->transfer(directions[k], jitters[k], out[k]);
        return;
    }
    // Thread t takes the directions t, t + T, ...; the first runs here. Each fills a
    // matrix of its own, on a cache line of its own, and swaps it into place: out[k] and
    // out[k + 1] share a cache line, and a backend appending to them directly would
    // have the threads write the same line at every entry.
    if (scratch_.size() < T) scratch_.resize(T);
    run_threads(static_cast<int>(T), [&](int t) {
        GeometryMatrix& mine = scratch_[static_cast<std::size_t>(t)].matrix;
        for (std::size_t k = static_cast<std::size_t>(t); k < n; k += T) {
            all_[static_cast<std::size_t>(t)]->transfer(directions[k], jitters[k], mine);
            std::swap(mine, out[k]);  // out[k]'s old storage is reused for the next one
        }
    });
}

}  // namespace raybundle::visibility
