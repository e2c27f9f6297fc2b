#include "commands/stop_signals.h"

#include <csignal>

#include "common/error.h"

namespace cofusion::commands {
namespace {

// A signal handler can only reach process-wide state; it touches nothing but this flag.
volatile std::sig_atomic_t g_requested = 0;
bool g_installed = false;
struct sigaction g_previous_int {}, g_previous_term {};

extern "C" void on_stop_signal(int signal) {
  if (g_requested == 0) g_requested = signal;
}

}  // namespace

StopSignals::StopSignals() {
  if (g_installed) throw Error("StopSignals: the stop handlers are installed already");
  g_requested = 0;
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  // Back to the default action after the first signal: a second one ends the process at once.
  // SA_RESTART: reads and waits the signal interrupts carry on; the run checks the flag per frame.
  action.sa_flags = SA_RESETHAND | SA_RESTART;
  sigaction(SIGINT, &action, &g_previous_int);
  sigaction(SIGTERM, &action, &g_previous_term);
  g_installed = true;
}

StopSignals::~StopSignals() {
  sigaction(SIGINT, &g_previous_int, nullptr);
  sigaction(SIGTERM, &g_previous_term, nullptr);
  g_installed = false;
}

int StopSignals::requested() const { return g_requested; }

const char* StopSignals::name(int signal) {
  switch (signal) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    default: return "signal";
  }
}

}  // namespace cofusion::commands
