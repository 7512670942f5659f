#pragma once
/// Cooperative cancellation (DESIGN.md, "The pipeline API": every method's context carries a
/// cancellation flag). A flag is set from any thread or from a signal handler; long loops poll
/// it and stop by throwing Cancelled, which unwinds like any error: temporary output files are
/// removed, nothing half-written is left (formfactor/core/atomic_file.h).

#include <atomic>
#include <string>

#include "formfactor/core/error.h"

namespace formfactor {

/// Thrown when a computation stopped because its cancellation flag was set: nothing is wrong
/// with the input, the caller asked it to stop.
class Cancelled : public Error {
  public:
    Cancelled() : Error("cancelled") {}
    explicit Cancelled(const std::string& message) : Error(message) {}
};

/// A cancellation request. request() is lock-free and async-signal-safe (a signal handler may
/// call it); polling it costs one relaxed atomic load.
class CancellationFlag {
  public:
    constexpr CancellationFlag() noexcept = default;
    CancellationFlag(const CancellationFlag&) = delete;
    CancellationFlag& operator=(const CancellationFlag&) = delete;

    /// Asks every computation that polls this flag to stop.
    void request() noexcept { requested_.store(true, std::memory_order_relaxed); }
    /// True once request() was called (until reset()).
    bool requested() const noexcept { return requested_.load(std::memory_order_relaxed); }
    /// Clears the request (for a caller that goes on after a cancelled computation).
    void reset() noexcept { requested_.store(false, std::memory_order_relaxed); }
    /// Throws Cancelled when a request is pending.
    void throw_if_requested() const {
        if (requested()) throw Cancelled();
    }

  private:
    static_assert(std::atomic<bool>::is_always_lock_free, "a signal handler sets the flag");
    std::atomic<bool> requested_{false};
};

/// The process-wide flag. The CLI's SIGINT / SIGTERM handlers set it; the atomic output writers
/// poll it, and every computation that was given no flag of its own.
CancellationFlag& process_cancellation() noexcept;

/// The flag of the computation running on this thread: the one a CancellationScope installed,
/// else process_cancellation(). parallel_for() reads it on the calling thread and polls it in
/// every worker, so a computation's flag reaches all its loops without being passed down.
const CancellationFlag& current_cancellation() noexcept;

/// Installs `flag` as current_cancellation() of this thread until the scope ends (scopes nest).
/// The pipeline opens one around each computation it was given a flag for.
class CancellationScope {
  public:
    explicit CancellationScope(const CancellationFlag& flag) noexcept;
    ~CancellationScope();
    CancellationScope(const CancellationScope&) = delete;
    CancellationScope& operator=(const CancellationScope&) = delete;

  private:
    const CancellationFlag* previous_;
};

}  // namespace formfactor
