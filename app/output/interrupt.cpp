#include "output/interrupt.h"

#include <atomic>
#include <csignal>
#include <cstdlib>

#include <unistd.h>

namespace tsf::app {
namespace {

std::atomic<int> g_signal{0};
using Handler = void (*)(int);
Handler g_previous_int = SIG_DFL;
Handler g_previous_term = SIG_DFL;

extern "C" void on_signal(int sig) {
  if (g_signal.exchange(sig) != 0) std::_Exit(128 + sig);  // the second signal: stop now
  static const char kMessage[] =
      "\ntsf: stopping after the current stage or frame and writing the report (press Ctrl-C "
      "again to stop at once)\n";
  // write(2) is async-signal-safe; its result is of no use here.
  [[maybe_unused]] const ssize_t n = write(2, kMessage, sizeof kMessage - 1);
}

}  // namespace

InterruptScope::InterruptScope() {
  g_signal = 0;
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
