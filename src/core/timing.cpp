#include "formfactor/core/timing.h"

namespace formfactor {

void StepTimes::add(const std::string& name, double seconds) {
    for (auto& [n, s] : steps) {
        if (n == name) {
            s += seconds;
            return;
        }
    }
    steps.emplace_back(name, seconds);
}

void StepTimes::add(const StepTimes& other) {
    for (const auto& [name, s] : other.steps) add(name, s);
}

double StepTimes::sum() const {
    double s = 0.0;
    for (const auto& step : steps) s += step.second;
    return s;
}

}  // namespace formfactor
