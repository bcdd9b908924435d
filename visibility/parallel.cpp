#include "visibility/parallel.h"

#include "scenes/threads.h"
#include "visibility/patch_arrays.h"

#include <algorithm>
#include <atomic>

namespace raybundle::visibility {

BackendSet::BackendSet(const std::string& name, const scenes::Scene& scene, const BackendOptions& options,
                       int threads)
    : threads_(std::max(1, threads)) {
    // Made side by side too: each holds vectors the size of the scene (at 121k
    // patches, 16 backends made one after another took a quarter of a second). What
    // they only read is made once and shared: the scene's patch arrays, and the map's
    // resolution where the scene decides it.
    const BackendInfo& info = backend_info(name);
    const int n = info.side_by_side ? std::max(1, threads) : 1;
    BackendOptions shared = options;
    std::shared_ptr<const PatchArrays> arrays;
    if (info.discrete && n > 1) {
        if (shared.resolution <= 0) shared.resolution = default_resolution(scene);
        arrays = std::make_shared<const PatchArrays>(scene);
    }
    owned_.resize(static_cast<std::size_t>(n));
    run_threads(n, [&](int k) { owned_[static_cast<std::size_t>(k)] = make_backend(name, scene, shared, arrays); });
    for (const auto& b : owned_) all_.push_back(b.get());
}

BackendSet::BackendSet(Backend& single) { all_.push_back(&single); }

void BackendSet::transfer_batch(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                                std::vector<GeometryMatrix>& out, const std::function<void()>& alongside) {
    const std::size_t n = directions.size();
    out.resize(n);
    const std::size_t T = std::min(all_.size(), std::max<std::size_t>(n, 1));
    if (T <= 1) {
        all_[0]->transfer_many(directions, jitters, out, all_.size() == 1 ? threads_ : 1, alongside);
        return;
    }
    // Each thread takes the next direction not yet taken. It fills a matrix of its own,
    // on a cache line of its own, and swaps it into place: out[k] and out[k + 1] share a
    // cache line, and a backend appending to them directly would have the threads
    // write the same line at every entry. A matrix depends on its direction and jitter
    // alone, so which thread computes it does not change the result.
    if (scratch_.size() < T) scratch_.resize(T);
    std::atomic<std::size_t> next{0};
    run_threads(static_cast<int>(T), [&](int t) {
        if (t == 0 && alongside) alongside();
        GeometryMatrix& mine = scratch_[static_cast<std::size_t>(t)].matrix;
        for (std::size_t k = next.fetch_add(1, std::memory_order_relaxed); k < n;
             k = next.fetch_add(1, std::memory_order_relaxed)) {
            all_[static_cast<std::size_t>(t)]->transfer(directions[k], jitters[k], mine);
            std::swap(mine, out[k]);  // out[k]'s old storage is reused for the next one
        }
    });
}

}  // namespace raybundle::visibility
