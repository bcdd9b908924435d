#include "solver/pipeline.h"

#include "scenes/threads.h"

#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <stdexcept>

namespace raybundle::solver {

long run_step_streams(std::vector<StepStream>& streams, int threads, const std::function<bool(long item)>& go_on) {
    std::vector<visibility::Backend*> backends;
    std::vector<std::size_t> home;  // per backend, the stream it came with
    for (std::size_t s = 0; s < streams.size(); ++s) {
        const StepStream& stream = streams[s];
        if (stream.count > 0 && (stream.window < 1 || !stream.begin || !stream.compute || !stream.finish))
            throw std::logic_error("run_step_streams: a stream without a window or a callback");
        backends.insert(backends.end(), stream.backends.begin(), stream.backends.end());
        home.insert(home.end(), stream.backends.size(), s);
    }
    if (backends.empty()) throw std::logic_error("run_step_streams: no backend");
    const int T = std::max(1, std::min(threads, static_cast<int>(backends.size())));

    struct State {
        long begun = 0, finished = 0;
        bool finishing = false;     // a thread is finishing this stream's items
        std::vector<char> computed;  // per slot
    };
    std::vector<State> state(streams.size());
    std::vector<long> count(streams.size());  // the streams' counts, or where go_on said no
    long longest = 0;
    for (std::size_t s = 0; s < streams.size(); ++s) {
        state[s].computed.assign(static_cast<std::size_t>(std::max(1L, streams[s].window)), 0);
        count[s] = std::max(0L, streams[s].count);
        longest = std::max(longest, count[s]);
    }
    long asked = -1;  // go_on asked for items 0..asked
    std::mutex lock_all;
    std::condition_variable changed;
    bool failed = false;
    auto slot_of = [&](std::size_t s, long item) { return item % streams[s].window; };
    auto all_finished = [&] {
        for (std::size_t s = 0; s < streams.size(); ++s)
            if (state[s].finished < count[s]) return false;
        return true;
    };

    run_threads(T, [&](int t) {
        visibility::Backend& backend = *backends[static_cast<std::size_t>(t)];
        const std::size_t mine = home[static_cast<std::size_t>(t)];
        std::unique_lock<std::mutex> lock(lock_all);
        try {
            while (!failed && !all_finished()) {
                // The serial part first: it frees the window's slots.
                std::size_t f = streams.size();
                for (std::size_t s = 0; s < streams.size() && f == streams.size(); ++s) {
                    const State& st = state[s];
                    if (!st.finishing && st.finished < count[s] &&
                        st.computed[static_cast<std::size_t>(slot_of(s, st.finished))])
                        f = s;
                }
                if (f < streams.size()) {
                    State& st = state[f];
                    st.finishing = true;
                    while (!failed && st.finished < count[f] &&
                           st.computed[static_cast<std::size_t>(slot_of(f, st.finished))]) {
                        const long item = st.finished, slot = slot_of(f, item);
                        lock.unlock();
                        streams[f].finish(item, slot);
                        lock.lock();
                        st.computed[static_cast<std::size_t>(slot)] = 0;
                        ++st.finished;
                        changed.notify_all();  // a slot free, or the stream done
                    }
                    st.finishing = false;
                    changed.notify_all();  // another thread may finish what came in meanwhile
                    continue;
                }
                // Else the next item of the thread's own stream (the one its backend came
                // with: its items' vectors stay in this core's caches), or where that has
                // none to begin, of the stream least far along that has room.
                auto has_room = [&](std::size_t s) {
                    const State& st = state[s];
                    return st.begun < count[s] && st.begun < st.finished + streams[s].window;
                };
                std::size_t b = streams.size();
                if (has_room(mine)) {
                    b = mine;
                } else {
                    double least = 2.0;
                    for (std::size_t s = 0; s < streams.size(); ++s) {
                        if (!has_room(s)) continue;
                        const double along = static_cast<double>(state[s].begun) / static_cast<double>(count[s]);
                        if (along < least) least = along, b = s;
                    }
                }
                if (b < streams.size() && go_on && state[b].begun > asked) {
                    // The first stream to reach item k asks for all: none has begun it
                    // (item 0 too: a stop between two calls begins nothing).
                    asked = state[b].begun;
                    if (!go_on(asked)) {
                        for (long& c : count) c = std::min(c, asked);
                        longest = asked;
                        changed.notify_all();  // the streams may be done
                        continue;
                    }
                }
                if (b < streams.size()) {
                    State& st = state[b];
                    const long item = st.begun++, slot = slot_of(b, item);
                    streams[b].begin(item, slot);
                    lock.unlock();
                    streams[b].compute(slot, backend);
                    lock.lock();
                    st.computed[static_cast<std::size_t>(slot)] = 1;
                    changed.notify_all();
                    continue;
                }
                changed.wait(lock);
            }
        } catch (...) {
            if (!lock.owns_lock()) lock.lock();
            failed = true;  // the others stop at their next look
            changed.notify_all();
            throw;
        }
    });
    return longest;
}

}  // namespace raybundle::solver
