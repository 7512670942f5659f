#include "formfactor/core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace formfactor {

namespace {
constexpr long long kUpdateNs = 100'000'000;
constexpr double kTerminalDelaySeconds = 1.0;  // a bar only for phases that take a while
}  // namespace

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

void TerminalProgress::update(const std::string& label, std::size_t done, std::size_t total,
                              double elapsed) {
    if (!stderr_is_terminal()) return;
    if (!drawn_ && elapsed < kTerminalDelaySeconds) return;
    const double frac = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
    const int width = 40;
    const int filled = static_cast<int>(frac * width + 0.5);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, '.');
    // Time left at the rate so far (units of a phase cost about the same on average).
    char left[48] = "";
    if (done > 0 && done < total)
        std::snprintf(left, sizeof left, ", about %.0fs left",
                      elapsed * static_cast<double>(total - done) / static_cast<double>(done));
    std::fprintf(stderr, "\r%s [%s] %5.1f%%  %.1fs%s\033[K", label.c_str(), bar.c_str(),
                 100.0 * frac, elapsed, left);
    std::fflush(stderr);
    drawn_ = true;
}

void TerminalProgress::finish(const std::string&) {
    if (!drawn_) return;
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
}

void TerminalProgress::note(const std::string& text) {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
    drawn_ = false;
    const std::string line = words_ ? words_(text) : text;
    std::fprintf(stderr, "formfactor: %s\n", line.c_str());
    std::fflush(stderr);
}

Progress::Progress(std::string label, std::size_t total, ProgressSink* sink)
    : label_(std::move(label)),
      total_(total),
      sink_(sink),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() { end(done_.load() >= total_); }

void Progress::advance(std::size_t k) {
    if (!sink_.load(std::memory_order_relaxed)) return;
    const std::size_t done = done_.fetch_add(k, std::memory_order_relaxed) + k;
    const long long now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::steady_clock::now() - start_)
                              .count();
    long long next = next_update_ns_.load(std::memory_order_relaxed);
    if (now < next) return;
    if (!next_update_ns_.compare_exchange_strong(next, now + kUpdateNs)) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (ProgressSink* sink = sink_.load())
        sink->update(label_, done, total_, 1e-9 * static_cast<double>(now));
}

void Progress::finish() { end(true); }

void Progress::end(bool completed) {
    std::lock_guard<std::mutex> lock(mutex_);
    ProgressSink* sink = sink_.exchange(nullptr);
    if (!sink) return;
    // A phase that ran to its end reports done = total once more, however short it was (a phase
    // left by an exception does not).
    if (completed) {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        sink->update(label_, total_, total_, elapsed);
    }
    sink->finish(label_);
}

}  // namespace formfactor
