#include "formfactor/core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <thread>

namespace formfactor {

int effective_threads(int threads) {
    if (threads > 0) return threads;
    const int hw = static_cast<int>(std::thread::hardware_concurrency());
    return hw > 0 ? hw : 1;
}

void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                  const CancellationFlag& cancel) {
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
    } else {
        tbb::task_arena arena(t);
        arena.execute(
            [&] { tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), run_range); });
    }
    // Read under the lock the workers wrote it under (ThreadSanitizer cannot see TBB's join).
    std::exception_ptr error;
    {
        std::lock_guard<std::mutex> lock(error_mutex);
        error = first_error;
    }
    if (error) std::rethrow_exception(error);
}

}  // namespace formfactor
