#pragma once
// Ctrl-C (SIGINT) and SIGTERM during `cofusion run`: the first asks the run to stop after the
// current frame and write its outputs; the handler then goes back to the default action, so a
// second signal of the same kind ends the process at once.
namespace cofusion::commands {

// Installs the handlers for its lifetime and restores the previous ones after. One at a time
// (a process has one set of handlers); a second throws cofusion::Error.
class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  // The signal that asked to stop (SIGINT or SIGTERM), or 0. Safe from any thread.
  int requested() const;
  // "SIGINT" / "SIGTERM" for requested().
  static const char* name(int signal);
};

}  // namespace cofusion::commands
