#include "scenes/threads.h"

#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <thread>

#include <pthread.h>
#include <signal.h>

namespace raybundle::detail {
namespace {

// The process's workers. Worker k (k >= 1) runs t = k of each region it takes part in,
// so a region on T threads wakes workers 1 .. T-1 and leaves the others asleep. One
// region at a time: the caller that finds them busy runs its region on threads of its
// own. Made on first use and never destroyed: its threads sleep in it until the process
// ends (joining them in a static destructor would race with whatever else runs at exit).
// Workers block SIGINT, SIGTERM and SIGHUP whatever the mask of the thread that starts
// them: those reach the program's signal thread (render/signals.h) or, in a program
// without one, its other threads, never a worker that lives on with them unblocked.
class Workers {
public:
    // Runs the region and returns true, or returns false at once where the workers are
    // busy with another region. Throws where a missing worker cannot be started, before
    // job has run.
    bool run(int count, const std::function<void(int)>& job) {
        bool idle = false;
        if (!busy_.compare_exchange_strong(idle, true, std::memory_order_acquire)) return false;
        struct Release {
            std::atomic<bool>& busy;
            ~Release() { busy.store(false, std::memory_order_release); }
        } release{busy_};
        grow(count - 1);
        {
            const std::lock_guard<std::mutex> lock(mutex_);
            job_ = &job;
            pending_ = count - 1;
            for (int k = 1; k < count; ++k) workers_[static_cast<std::size_t>(k - 1)]->go = true;
        }
        for (int k = 1; k < count; ++k) workers_[static_cast<std::size_t>(k - 1)]->wake.notify_one();
        job(0);
        std::unique_lock<std::mutex> lock(mutex_);
        done_.wait(lock, [this] { return pending_ == 0; });
        job_ = nullptr;
        return true;
    }

private:
    struct Worker {
        std::condition_variable wake;
        bool go = false;  // under mutex_
    };

    // At least n workers (only the region's caller grows them: busy_ is held).
    void grow(int n) {
        workers_.reserve(static_cast<std::size_t>(n));
        while (static_cast<int>(workers_.size()) < n) {
            workers_.push_back(std::make_unique<Worker>());
            const int t = static_cast<int>(workers_.size());
            sigset_t blocked, old;
            sigemptyset(&blocked);
            for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&blocked, sig);
            ::pthread_sigmask(SIG_BLOCK, &blocked, &old);  // the new thread inherits it
            try {
                std::thread(&Workers::serve, this, workers_.back().get(), t).detach();
            } catch (...) {
                ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
                workers_.pop_back();
                throw;
            }
            ::pthread_sigmask(SIG_SETMASK, &old, nullptr);
        }
    }

    [[noreturn]] void serve(Worker* self, int t) {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            self->wake.wait(lock, [self] { return self->go; });
            self->go = false;
            const std::function<void(int)>& job = *job_;
            lock.unlock();
            job(t);
            lock.lock();
            if (--pending_ == 0) done_.notify_one();
        }
    }

    std::atomic<bool> busy_{false};
    std::vector<std::unique_ptr<Worker>> workers_;  // only the caller holding busy_ changes it
    std::mutex mutex_;
    std::condition_variable done_;
    const std::function<void(int)>* job_ = nullptr;  // under mutex_
    int pending_ = 0;                                // workers of the region not done; under mutex_
};

// A region of threads of its own, started and joined here. Where one cannot be
// started, those started finish and the failure is rethrown (a clean error, not
// std::terminate for a thread never joined).
void spawn_region(int count, const std::function<void(int)>& job) {
    std::vector<std::thread> threads;
    std::exception_ptr start_failed;
    try {
        for (int t = 1; t < count; ++t) threads.emplace_back(job, t);
    } catch (...) {
        start_failed = std::current_exception();
    }
    if (!start_failed) job(0);
    for (auto& th : threads) th.join();
    if (start_failed) std::rethrow_exception(start_failed);
}

}  // namespace

void run_region(int count, const std::function<void(int)>& job) {
    static Workers* const workers = new Workers;
    if (!workers->run(count, job)) spawn_region(count, job);
}

}  // namespace raybundle::detail
