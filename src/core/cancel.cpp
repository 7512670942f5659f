#include "formfactor/core/cancel.h"

namespace formfactor {

namespace {
// Constant-initialised (no guard variable), so a signal handler may reach it at any time.
constinit CancellationFlag g_process_cancellation;
thread_local const CancellationFlag* t_current = nullptr;
}  // namespace

CancellationFlag& process_cancellation() noexcept { return g_process_cancellation; }

const CancellationFlag& current_cancellation() noexcept {
    return t_current ? *t_current : g_process_cancellation;
}

CancellationScope::CancellationScope(const CancellationFlag& flag) noexcept : previous_(t_current) {
    t_current = &flag;
}

CancellationScope::~CancellationScope() { t_current = previous_; }

}  // namespace formfactor
