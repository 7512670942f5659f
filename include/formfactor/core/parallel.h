#pragma once
/// Row-parallel loops over TBB. The thread count never changes a result: bodies must write only
/// their own rows and draw random numbers from streams seeded by (seed, i, j).

#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>

#include "formfactor/core/cancel.h"

namespace formfactor {

/// Runs body(i) for i in [0, n) on up to `threads` threads (0 = all cores). Iterations are
/// handed out in small chunks (dynamic load balance: rows differ in cost). The first exception
/// thrown by a body stops the remaining work and is rethrown on the calling thread, so none
/// escapes a worker. `cancel` (by default the calling thread's current_cancellation()) is polled
/// before every iteration: once it is requested, no new iteration starts and Cancelled is thrown on
/// the calling thread.
void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                  const CancellationFlag& cancel = current_cancellation());

/// parallel_for() with every iteration handed out on its own, for a few iterations of very
/// unequal cost (the classification's surface pairs: on a city, the ground against one row of
/// walls takes a second, most pairs a millisecond): in chunks, the costly ones that come
/// together would run one after the other on one thread while the others wait.
void parallel_for_each(std::size_t n, int threads, const std::function<void(std::size_t)>& body,
                       const CancellationFlag& cancel = current_cancellation());

/// Number of threads `threads` means on this machine (0 → hardware concurrency).
int effective_threads(int threads);

}  // namespace formfactor
