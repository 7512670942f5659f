#include "formfactor/core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace formfactor {

namespace {
constexpr long long kFirstDrawNs = 1'000'000'000;  // show the bar only after ~1 s
constexpr long long kRedrawNs = 100'000'000;
}  // namespace

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

Progress::Progress(std::string label, std::size_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled && stderr_is_terminal()),
      start_(std::chrono::steady_clock::now()) {
    next_draw_ns_ = kFirstDrawNs;
}

Progress::~Progress() { finish(); }

void Progress::advance(std::size_t k) {
    if (!enabled_) return;
    const std::size_t done = done_.fetch_add(k, std::memory_order_relaxed) + k;
    const long long now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::steady_clock::now() - start_)
                              .count();
    long long next = next_draw_ns_.load(std::memory_order_relaxed);
    if (now < next) return;
    if (!next_draw_ns_.compare_exchange_strong(next, now + kRedrawNs)) return;
    draw(done);
}

void Progress::draw(std::size_t done) {
    std::lock_guard<std::mutex> lock(mutex_);
    const double frac = total_ ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
    const int width = 40;
    const int filled = static_cast<int>(frac * width + 0.5);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, '.');
    std::fprintf(stderr, "\r%s [%s] %5.1f%%  %.1fs", label_.c_str(), bar.c_str(), 100.0 * frac,
                 elapsed);
    std::fflush(stderr);
    drawn_ = true;
}

void Progress::finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (drawn_) {
        std::fprintf(stderr, "\r\033[K");
        std::fflush(stderr);
        drawn_ = false;
    }
    enabled_ = false;
}

}  // namespace formfactor
