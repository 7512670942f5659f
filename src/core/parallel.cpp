#include "formfactor/core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <thread>
#include <vector>

// Under ThreadSanitizer the loop runs on std::threads instead of TBB: Debian's libtbb is not
// instrumented, so TSan cannot see how it orders its own task-tree nodes and reports races
// inside TBB's headers. Plain threads keep every synchronisation visible, and the bodies — our
// code — are checked without suppressions.
#if defined(__SANITIZE_THREAD__)
#define FF_PLAIN_THREADS 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define FF_PLAIN_THREADS 1
#endif
#endif

#ifdef FF_PLAIN_THREADS
#define FF_PLAIN_THREADS_ON true
#else
#define FF_PLAIN_THREADS_ON false
#endif

namespace formfactor {

int effective_threads(int threads) {
    if (threads > 0) return threads;
    const int hw = static_cast<int>(std::thread::hardware_concurrency());
    return hw > 0 ? hw : 1;
}

namespace {

void run_parallel(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                  const CancellationFlag& cancel, bool each) {
    cancel.throw_if_requested();
    if (n == 0) return;
    std::exception_ptr first_error;
    std::mutex error_mutex;
    std::atomic<bool> failed{false};
    auto run_range = [&](const tbb::blocked_range<std::size_t>& r) {
        if (failed.load(std::memory_order_relaxed)) return;
        try {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                cancel.throw_if_requested();
                body(i);
            }
        } catch (...) {
            std::lock_guard<std::mutex> lock(error_mutex);
            if (!first_error) first_error = std::current_exception();
            failed = true;
        }
    };
    const int t = effective_threads(threads);
    if (t == 1) {
        run_range(tbb::blocked_range<std::size_t>(0, n));
    } else if (FF_PLAIN_THREADS_ON) {
        std::atomic<std::size_t> next{0};
        auto worker = [&] {
            for (std::size_t i; (i = next.fetch_add(1)) < n;)
                run_range(tbb::blocked_range<std::size_t>(i, i + 1));
        };
        std::vector<std::thread> pool;
        for (int k = 1; k < t; ++k) pool.emplace_back(worker);
        worker();
        for (std::thread& th : pool) th.join();
    } else {
        tbb::task_arena arena(t);
        arena.execute([&] {
            if (each)
                tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), run_range,
                                  tbb::simple_partitioner());
            else
                tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), run_range);
        });
    }
    // Read under the lock the workers wrote it under (ThreadSanitizer cannot see TBB's join).
    std::exception_ptr error;
    {
        std::lock_guard<std::mutex> lock(error_mutex);
        error = first_error;
    }
    if (error) std::rethrow_exception(error);
}

}  // namespace

void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                  const CancellationFlag& cancel) {
    run_parallel(n, threads, body, cancel, false);
}

void parallel_for_each(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                       const CancellationFlag& cancel) {
    run_parallel(n, threads, body, cancel, true);
}

}  // namespace formfactor
