#include "formfactor/core/phase.h"

#include <atomic>

namespace formfactor {

namespace {
std::atomic<void (*)(const char*)> g_observer{nullptr};
}  // namespace

void announce_phase(const char* name) noexcept {
    if (auto* observer = g_observer.load(std::memory_order_acquire)) observer(name);
}

void set_phase_observer(void (*observer)(const char* name)) noexcept {
    g_observer.store(observer, std::memory_order_release);
}

}  // namespace formfactor
