#pragma once
// The program's one threading helper (every parallel loop goes through it).
//
// run_threads(count, body): body(t) for t = 0 .. count-1, each on a thread of its own
// (t = 0 on the caller's), returning when all have returned; the first exception a
// body throws (in t order) is rethrown after all have finished. The threads are the
// process's workers, started once and kept (worker k runs every region's t = k): a
// region costs a wake-up per thread, not a thread's start and end (on the 2-core
// development machine a region of 16 started and joined its threads in about 0.47 ms,
// woke kept ones in 0.08 ms; a run has 60-1,400 regions).
// A region started while the workers are busy (a body's own run_threads, or another
// thread's) gets threads of its own, started and joined as before. Where a thread
// cannot be started, run_threads throws std::system_error: for the workers before any
// body has run, for a region's own threads after the bodies started have returned.
//
// A body must leave nothing bound to its thread that another thread will want (an
// OpenGL context current on it, say: release it before returning), since the thread
// lives on and runs other regions' bodies.
//
// parallel_bands(rows, threads, body): body(y0, y1) on contiguous bands of rows.
// parallel_rows(rows, threads, body): body(y) for every row, each row taken by the next
// thread free (balances rows of uneven cost: the threads end within a row of each other;
// dealt in fixed turns, the final gather's guide rows left one thread alone for the
// last 10-16 ms of each pass).
// parallel_chunks(items, threads, body[, per_thread]): body(i0, i1) on chunks of about
// items / (per_thread threads) items (16 per thread by default), each taken by the next
// thread free (balances items whose cost is clustered in index order, e.g. the patches
// next to a light; more chunks balance better and cost an atomic add each). A body that takes a third
// argument gets the thread's index t < min(threads, items) too (for scratch space of
// its own, never for what it computes).
//
// parallel_sort(values, threads, less): sorts values by a strict total order (no two
// distinct values equivalent: then every correct sort gives the same sequence, on any
// number of threads). Fixed parts sorted on the threads, then merged in pairs.
//
// Results must not depend on the number of threads: bodies write disjoint outputs and
// draw random numbers from streams chosen by row or pixel, never by thread.
#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <thread>
#include <type_traits>
#include <vector>

namespace raybundle {

namespace detail {
// job(t) for t = 0 .. count-1 (count >= 2), t = 0 on the caller's thread, on the
// workers where they are free (scenes/threads.cpp); returns when all have returned.
// job must not throw.
void run_region(int count, const std::function<void(int)>& job);
}  // namespace detail

template <class Body>
void run_threads(int count, const Body& body) {
    if (count <= 0) return;
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(count));
    auto run = [&](int t) {
        try {
            body(t);
        } catch (...) {
            errors[static_cast<std::size_t>(t)] = std::current_exception();
        }
    };
    if (count == 1)
        run(0);
    else
        detail::run_region(count, run);
    for (const auto& e : errors)
        if (e) std::rethrow_exception(e);
}

template <class Body>
void parallel_bands(int rows, int threads, const Body& body) {
    const int n = std::max(1, std::min(threads, rows));
    if (n == 1) {
        body(0, rows);
        return;
    }
    run_threads(n, [&](int t) {
        body(static_cast<int>(static_cast<long long>(rows) * t / n),
             static_cast<int>(static_cast<long long>(rows) * (t + 1) / n));
    });
}

template <class Body>
void parallel_rows(int rows, int threads, const Body& body) {
    const int n = std::max(1, std::min(threads, rows));
    if (n == 1) {
        for (int y = 0; y < rows; ++y) body(y);
        return;
    }
    std::atomic<int> next{0};
    run_threads(n, [&](int) {
        for (int y = next.fetch_add(1, std::memory_order_relaxed); y < rows; y = next.fetch_add(1, std::memory_order_relaxed))
            body(y);
    });
}

template <class Body>
void parallel_chunks(int items, int threads, const Body& body, int chunks_per_thread = 16) {
    auto call = [&body](int i0, int i1, int t) {
        if constexpr (std::is_invocable_v<const Body&, int, int, int>)
            body(i0, i1, t);
        else
            body(i0, i1);
    };
    const int n = std::max(1, std::min(threads, items));
    if (n == 1) {
        call(0, items, 0);
        return;
    }
    const long long chunk = std::max(1LL, items / (static_cast<long long>(std::max(1, chunks_per_thread)) * n));
    std::atomic<long long> next{0};
    run_threads(n, [&](int t) {
        for (long long i0 = next.fetch_add(chunk, std::memory_order_relaxed); i0 < items;
             i0 = next.fetch_add(chunk, std::memory_order_relaxed))
            call(static_cast<int>(i0), static_cast<int>(std::min<long long>(items, i0 + chunk)), t);
    });
}

template <class T, class Less>
void parallel_sort(std::vector<T>& values, int threads, const Less& less) {
    const std::size_t n = values.size();
    // Parts of at least 4,096 values: below that the threads cost more than they save.
    // (Pairs of a double and an int on 2 threads: 12,000 in 0.69 -> 0.50 ms, 24,000 in
    // 1.49 -> 0.99 ms, against parts of at least 16k; 6,000 the same either way.)
    const auto parts = static_cast<std::size_t>(std::max(1, std::min<int>(threads, static_cast<int>(n / 4096))));
    if (parts == 1) {
        std::sort(values.begin(), values.end(), less);
        return;
    }
    auto bound = [&](std::size_t p) { return n * std::min(p, parts) / parts; };
    run_threads(static_cast<int>(parts), [&](int t) {
        const auto p = static_cast<std::size_t>(t);
        std::sort(values.begin() + static_cast<long>(bound(p)), values.begin() + static_cast<long>(bound(p + 1)), less);
    });
    std::vector<T> other(n);
    std::vector<T>* from = &values;
    std::vector<T>* to = &other;
    for (std::size_t width = 1; width < parts; width *= 2) {
        const std::size_t pairs = (parts + 2 * width - 1) / (2 * width);
        run_threads(static_cast<int>(pairs), [&](int t) {
            const std::size_t p = 2 * width * static_cast<std::size_t>(t);
            const auto a = static_cast<long>(bound(p)), m = static_cast<long>(bound(p + width)),
                       b = static_cast<long>(bound(p + 2 * width));
            std::merge(from->begin() + a, from->begin() + m, from->begin() + m, from->begin() + b, to->begin() + a, less);
        });
        std::swap(from, to);
    }
    if (from != &values) values.swap(other);
}

// The number of hardware threads (at least 1).
inline int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace raybundle
