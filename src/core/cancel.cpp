#include "formfactor/core/cancel.h"

namespace formfactor {

namespace {
// Constant-initialised (no guard variable), so a signal handler may reach it at any time.
constinit CancellationFlag g_process_cancellation;
}  // namespace

CancellationFlag& process_cancellation() noexcept { return g_process_cancellation; }

}  // namespace formfactor
