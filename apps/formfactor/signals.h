#pragma once
// SIGINT and SIGTERM: the first one asks the library to stop (process_cancellation()). The
// computation ends at its next check (every row of every method, every solver sweep, before
// every output is renamed into place), the temporaries are removed as the Cancelled exception
// unwinds, and main() prints one line and dies of the same signal, as a shell expects. A second
// signal of the same kind is not caught: it ends the process at once.

namespace formfactor::cli {

/// Installs the handlers (a signal that was ignored when the program started stays ignored).
/// With FORMFACTOR_TEST_PHASES set, each long phase prints "formfactor: phase NAME" on stderr as
/// it starts, for the tests that interrupt every phase.
void install_signal_handlers();
/// The signal that asked the process to stop, 0 when none did.
int received_signal();
/// "SIGINT", "SIGTERM" or "signal N".
const char* signal_name(int sig);
/// Restores the default action of `sig` and raises it (the exit status then says "killed by
/// sig"); returns 128 + sig if the process survives that.
int die_of_signal(int sig);

}  // namespace formfactor::cli
