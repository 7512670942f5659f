#include "signals.h"

#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstring>

#include "formfactor/core/cancel.h"
#include "formfactor/core/phase.h"

namespace formfactor::cli {

namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_stop_signal(int sig) {
    // Only async-signal-safe work: a lock-free atomic store and a sig_atomic_t.
    if (g_signal == 0) g_signal = sig;
    process_cancellation().request();
}

void install(int sig) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) return;
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;  // the second signal takes the default action
    ::sigaction(sig, &sa, nullptr);
}

// One unbuffered write, so that a test reading stderr sees the line before the phase's work.
void print_phase(const char* name) {
    char line[128] = "formfactor: phase ";
    std::strncat(line, name, sizeof line - std::strlen(line) - 2);
    std::strcat(line, "\n");
    [[maybe_unused]] const ssize_t written = ::write(2, line, std::strlen(line));
}

}  // namespace

void install_signal_handlers() {
    install(SIGINT);
    install(SIGTERM);
    if (std::getenv("FORMFACTOR_TEST_PHASES")) set_phase_observer(print_phase);
}

int received_signal() { return g_signal; }

const char* signal_name(int sig) {
    switch (sig) {
        case SIGINT:
            return "SIGINT";
        case SIGTERM:
            return "SIGTERM";
        default:
            return "a signal";
    }
}

int die_of_signal(int sig) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
    return 128 + sig;
}

}  // namespace formfactor::cli
