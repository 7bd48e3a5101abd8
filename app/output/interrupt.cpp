#include "output/interrupt.h"

#include <atomic>
#include <csignal>
#include <cstdlib>

#include <time.h>
#include <unistd.h>

#include "tsf/common/atomic_file.h"

namespace tsf::app {
namespace {

std::atomic<int> g_signal{0};
using Handler = void (*)(int);
Handler g_previous_int = SIG_DFL;
Handler g_previous_term = SIG_DFL;

std::atomic<long long> g_first_ns{0};

long long monotonic_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);  // async-signal-safe
  return static_cast<long long>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

extern "C" void on_signal(int sig) {
  // A second signal a person sends (a second Ctrl-C) stops at once. One arriving within a second
  // of the first is the same request delivered twice (`timeout` and `kill` on the process
  // group send it to the process and to its group) and is ignored.
  if (g_signal.load() != 0) {
    if (monotonic_ns() - g_first_ns.load() > 1000000000LL) {
      remove_pending_temporaries();
      std::_Exit(128 + sig);
    }
    return;
  }
  g_first_ns = monotonic_ns();
  g_signal = sig;
  static const char kMessage[] =
      "\ntsf: stopping after the current stage or frame and writing the report (press Ctrl-C "
      "again to stop at once)\n";
  // write(2) is async-signal-safe; its result is of no use here.
  [[maybe_unused]] const ssize_t n = write(2, kMessage, sizeof kMessage - 1);
}

extern "C" void on_signal_cleanup(int sig) {
  remove_pending_temporaries();
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

}  // namespace

void remove_temporaries_on_signal() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    // A signal ignored when tsf started (nohup, a background job) stays ignored.
    const Handler previous = std::signal(sig, on_signal_cleanup);
    if (previous == SIG_IGN) std::signal(sig, SIG_IGN);
  }
}

InterruptScope::InterruptScope() {
  g_signal = 0;
  g_first_ns = 0;
  g_previous_int = std::signal(SIGINT, on_signal);
  g_previous_term = std::signal(SIGTERM, on_signal);
}

InterruptScope::~InterruptScope() {
  std::signal(SIGINT, g_previous_int == SIG_ERR ? SIG_DFL : g_previous_int);
  std::signal(SIGTERM, g_previous_term == SIG_ERR ? SIG_DFL : g_previous_term);
}

bool interrupted() {
  return g_signal.load() != 0;
}

int interrupt_signal() {
  return g_signal.load();
}

}  // namespace tsf::app
