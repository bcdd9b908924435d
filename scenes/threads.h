#pragma once
// run_threads(count, body): body(t) for t = 0 .. count-1, each on its own thread (t = 0
// on the caller's). Every started thread is joined, also when starting another one
// fails (the failure is then rethrown: a clean error, not std::terminate); the first
// exception a body throws is rethrown after all have finished.
#include <exception>
#include <thread>
#include <vector>

namespace raybundle {

template <class Body>
void run_threads(int count, const Body& body) {
    std::vector<std::exception_ptr> errors(count > 0 ? static_cast<std::size_t>(count) : 0);
    auto run = [&](int t) {
        try {
            body(t);
        } catch (...) {
            errors[static_cast<std::size_t>(t)] = std::current_exception();
        }
    };
    std::vector<std::thread> pool;
    std::exception_ptr start_failed;
    try {
        for (int t = 1; t < count; ++t) pool.emplace_back(run, t);
    } catch (...) {
        start_failed = std::current_exception();
    }
    if (!start_failed && count > 0) run(0);
    for (auto& th : pool) th.join();
    if (start_failed) std::rethrow_exception(start_failed);
    for (const auto& e : errors)
        if (e) std::rethrow_exception(e);
}

}  // namespace raybundle
