#pragma once
/// A progress bar on stderr, shown only when stderr is a terminal and the work has already
/// taken about a second. Thread-safe: workers call advance().

#include <atomic>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace formfactor {

class Progress {
  public:
    /// `total` units of work labelled `label`; `enabled` false makes every call a no-op.
    Progress(std::string label, std::size_t total, bool enabled = true);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    /// Marks `k` more units done (thread-safe, cheap).
    void advance(std::size_t k = 1);
    /// Clears the bar (called by the destructor too).
    void finish();

  private:
    void draw(std::size_t done);
    std::string label_;
    std::size_t total_;
    bool enabled_;
    bool drawn_ = false;
    std::atomic<std::size_t> done_{0};
    std::atomic<long long> next_draw_ns_{0};
    std::chrono::steady_clock::time_point start_;
    std::mutex mutex_;
};

/// True when stderr is a terminal.
bool stderr_is_terminal();

}  // namespace formfactor
