#pragma once
/// The long phases of a run (the rows, the threshold into CSR, the diagnosis, a repair, a solve,
/// the writing) name themselves as they start, to one process-wide observer: none by default.
/// The CLI's interrupt tests install one (FORMFACTOR_TEST_PHASES) to send a signal during each
/// phase and check that every phase polls its cancellation flag.

namespace formfactor {

/// Tells the observer, if any, that phase `name` starts now. Cheap when there is none.
void announce_phase(const char* name) noexcept;

/// Installs `observer` (nullptr removes it); any thread may announce a phase to it.
void set_phase_observer(void (*observer)(const char* name)) noexcept;

}  // namespace formfactor
