#pragma once
/// Wall-clock timing of the steps of a run.

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace formfactor {

/// Wall-clock seconds per named step, in the order they ran.
struct StepTimes {
    std::vector<std::pair<std::string, double>> steps;
    /// Appends (or adds to) the step `name`.
    void add(const std::string& name, double seconds);
    /// Adds every step of `other`.
    void add(const StepTimes& other);
    /// Sum of the steps.
    double sum() const;
};

/// Wall-clock stopwatch.
class Stopwatch {
  public:
    Stopwatch() : start_(std::chrono::steady_clock::now()) {}
    /// Seconds since construction or the last lap().
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }
    /// Returns seconds() and restarts.
    double lap() {
        const double s = seconds();
        start_ = std::chrono::steady_clock::now();
        return s;
    }

  private:
    std::chrono::steady_clock::time_point start_;
};

}  // namespace formfactor
