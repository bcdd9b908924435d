#pragma once
// Geometry matrices on several threads: one backend per thread, each matrix a function
// of its direction and jitter alone, so that the result does not depend on the number
// of threads. The solvers hand the backends to solver/pipeline.h, whose threads each
// take one; a walk whose steps depend on each other computes its D directions through
// transfer_batch(), and a backend that cannot run side by side (a GPU's) takes whole
// batches there.
//
// Call order: make a BackendSet once (it makes one backend per thread through the
// factory), then transfer_batch() as often as needed.
#include "visibility/backend.h"

#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace raybundle::visibility {

class BackendSet {
public:
    // `threads` backends of the named kind; backends that cannot run side by side
    // (the OpenGL z-buffer: one context) are made once, and threads() says so.
    BackendSet(const std::string& name, const scenes::Scene& scene, const BackendOptions& options, int threads);
    // Wraps one backend that the caller owns (one thread).
    explicit BackendSet(Backend& single);

    Backend& front() { return *all_.front(); }
    Backend& at(int t) { return *all_[static_cast<std::size_t>(t)]; }
    // Backends that run at once: the threads the set was made for, or 1 for a backend
    // that cannot run side by side.
    int threads() const { return static_cast<int>(all_.size()); }
    // The directions a solver should hand transfer_batch() at once: 4 per thread with
    // backends side by side (each thread takes the next as it finishes one), else what
    // the one backend batches (a GPU's submission: the solver then batches its steps),
    // else 1.
    int batch_directions() const {
        return all_.size() > 1 ? 4 * threads() : std::max(1, all_.front()->batch_directions());
    }

    // out[k] = A(directions[k]) with jitters[k]; out is resized to the batch. The
    // threads take the directions in turn as they finish the one before (a direction's
    // cost varies with how the scene lies along it), each with its own backend.
    //
    // alongside, when given, runs first on the calling thread while the others start
    // on the batch; the calling thread then joins them. A solver moves the light along
    // one batch's matrices this way while the next batch's are computed: its serial
    // part overlaps the parallel one. alongside must not touch `out`. One backend (it
    // cannot run side by side) gets the whole batch (Backend::transfer_many) with the
    // set's threads for its CPU work, and alongside while its GPU works.
    void transfer_batch(const std::vector<Vec3>& directions, const std::vector<Eigen::Vector2d>& jitters,
                        std::vector<GeometryMatrix>& out, const std::function<void()>& alongside = {});

private:
    std::vector<std::unique_ptr<Backend>> owned_;
    std::vector<Backend*> all_;
    int threads_ = 1;  // the threads the set was made for
    struct alignas(64) Scratch {
        GeometryMatrix matrix;
    };
    std::vector<Scratch> scratch_;  // one per thread (transfer_batch)
};

}  // namespace raybundle::visibility
