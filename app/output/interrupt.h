// Ctrl-C (SIGINT) and SIGTERM during a long run: the run stops at the next frame, writes its
// report marked "interrupted" with what it has, removes temporary files and exits non-zero,
// instead of dying with no report. A second signal more than a second later (a second
// Ctrl-C) ends the process at once (temporaries of writes in progress removed); one within a
// second is the same request delivered twice.
#pragma once

namespace tsf::app {

/// For the whole process (called once from main): SIGINT, SIGTERM or SIGHUP outside an
/// InterruptScope removes the temporaries of writes in progress (atomic_file.h) and ends the
/// process as the signal would, so no command leaves hidden `.name.tmp-*` files behind; finished
/// outputs are complete files, since each is renamed into place whole.
void remove_temporaries_on_signal();

/// Installs the handlers while alive; restores the previous ones when destroyed.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;
};

/// True once SIGINT or SIGTERM arrived inside an InterruptScope.
bool interrupted();

/// The signal that arrived (SIGINT, SIGTERM) or 0.
int interrupt_signal();

}  // namespace tsf::app
