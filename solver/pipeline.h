#pragma once
// The steps of one or more chains on shared threads, without a barrier between them.
//
// A StepStream is `count` items in order: a chain's steps (stochastic iteration) or
// walks in one advance. Each item is
//   begun     in item order, one at a time, under the pipeline's lock (its random
//             draws: cheap),
//   computed  by any thread beside other items (a step's geometry matrices, a whole
//             walk): a function of what `begin` drew alone, written to its slot only,
//   finished  in item order, one at a time (the light moved along the matrices, the
//             walk summed): the chain's serial part.
// At most `window` items of a stream are begun and not yet finished; item k uses slot
// k % window. A thread free finishes a stream's next items where they are computed and
// no other thread is finishing that stream; else it begins and computes the next item
// of its own stream (the one its backend came with), or where that has none to begin,
// of the stream least far along; it waits only where it can do neither. So the
// streams' serial parts overlap each other's and the computing, no thread waits for a
// batch to end, and streams run together end within about one item of each other (the
// chains of a run, side by side: a pause waits for both).
//
// What the items compute does not depend on the threads: begin and finish run in item
// order, compute writes only its item's slot, and the backends are interchangeable.
#include "visibility/backend.h"

#include <functional>
#include <vector>

namespace raybundle::solver {

struct StepStream {
    long count = 0;   // items
    long window = 1;  // items begun and not yet finished, at most
    std::function<void(long item, long slot)> begin;
    std::function<void(long slot, visibility::Backend& backend)> compute;
    std::function<void(long item, long slot)> finish;
    // The stream's backends: one thread each. The streams run together share all of
    // them, so they must be interchangeable (one kind, one scene, the same options).
    std::vector<visibility::Backend*> backends;
};

// Runs the streams' items on min(threads, all their backends) threads, thread t with
// backend t. The first exception a callback throws stops every thread (their items
// under way end first) and is rethrown; the streams are then in no defined state.
//
// With `go_on`, the streams can be stopped together without waiting for them: before
// any stream begins its item k (k >= 0), go_on(k) is asked, once for each k, under the
// pipeline's lock (it must be quick: a stop request read). Where it says no, every
// stream ends at k items: its items from k on are never begun, those before k are
// finished. (Streams that stop together this way need no pause between their items, at
// which every thread but the last waits for the last item under way.) Returns k where
// go_on said no at k, else the largest count: each stream ran min(its count, that).
long run_step_streams(std::vector<StepStream>& streams, int threads,
                      const std::function<bool(long item)>& go_on = {});

// One stream alone, a thread per backend of its own.
inline void run_step_stream(StepStream stream) {
    const int threads = static_cast<int>(stream.backends.size());
    std::vector<StepStream> one{std::move(stream)};
    run_step_streams(one, threads);
}

}  // namespace raybundle::solver
