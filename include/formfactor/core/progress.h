#pragma once
/// Progress of long phases. A library draws nothing unless asked: a computation reports to the
/// ProgressSink its caller gave (none by default). The CLI gives a TerminalProgress (a bar on
/// stderr); the Python module a callback.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

namespace formfactor {

/// Receives the progress of a computation, one phase at a time. Calls are serialised (never two
/// at once) but may come from any thread.
class ProgressSink {
  public:
    virtual ~ProgressSink() = default;
    /// Phase `label` has `done` of `total` units done: called when its first units are done, then
    /// at most ~10 times a second, and once more with done = total when it ends (also when it
    /// took less than 100 ms; not when an error or a cancellation ended it).
    virtual void update(const std::string& label, std::size_t done, std::size_t total,
                        double elapsed_seconds) = 0;
    /// The phase is over: clear what update() drew.
    virtual void finish(const std::string& label) = 0;
    /// A line for the user before a long phase (what it will cost, what would cost less).
    /// Ignored by default.
    virtual void note(const std::string& text) { (void)text; }
};

/// A bar on stderr, drawn only when stderr is a terminal and the phase has already taken about a
/// second.
class TerminalProgress final : public ProgressSink {
  public:
    TerminalProgress() = default;
    /// Notes pass through `words` first (a front end's names for the library's backquoted
    /// option names).
    explicit TerminalProgress(std::function<std::string(const std::string&)> words)
        : words_(std::move(words)) {}
    void update(const std::string& label, std::size_t done, std::size_t total,
                double elapsed_seconds) override;
    void finish(const std::string& label) override;
    /// Printed on stderr as "formfactor: text" (terminal or not).
    void note(const std::string& text) override;

  private:
    bool drawn_ = false;
    std::function<std::string(const std::string&)> words_;
};

/// The handle a method holds for one phase: counts units (thread-safe, cheap) and forwards to
/// the sink at once, then at most every 100 ms, and at its end. A null sink makes every call a
/// no-op.
class Progress {
  public:
    Progress(std::string label, std::size_t total, ProgressSink* sink);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    /// Marks `k` more units done.
    void advance(std::size_t k = 1);
    /// Ends the phase, which ran to its end: the sink sees done = total. (The destructor ends a
    /// phase not finished, as when an exception leaves it: done = total only if it was.)
    void finish();

  private:
    void end(bool completed);

    std::string label_;
    std::size_t total_;
    std::atomic<ProgressSink*> sink_;
    std::atomic<std::size_t> done_{0};
    std::atomic<long long> next_update_ns_{0};
    std::chrono::steady_clock::time_point start_;
    std::mutex mutex_;
};

/// True when stderr is a terminal.
bool stderr_is_terminal();

}  // namespace formfactor
