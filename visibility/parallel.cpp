#include "visibility/parallel.h"

#include <algorithm>
#include <exception>
#include <thread>

namespace raybundle::visibility {

BackendSet::BackendSet(const std::string& name, const scenes::Scene& scene, const BackendOptions& options,
                       int threads) {
    const int n = name == "zbuffer" ? 1 : std::max(1, threads);
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
    // Thread t takes the directions t, t + T, ...; the first runs here.
    std::vector<std::exception_ptr> errors(T);
    auto work = [&](std::size_t t) {
        try {
            for (std::size_t k = t; k < n; k += T) all_[t]->transfer(directions[k], jitters[k], out[k]);
        } catch (...) {
            errors[t] = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    for (std::size_t t = 1; t < T; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& th : pool) th.join();
    for (const auto& e : errors)
        if (e) std::rethrow_exception(e);
}

}  // namespace raybundle::visibility
