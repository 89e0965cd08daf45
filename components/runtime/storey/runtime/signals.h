// SIGINT/SIGTERM handling without asynchronous handlers: the signals are blocked (in the
// calling thread and every thread started afterwards) and taken with sigtimedwait.
#pragma once

#include <csignal>

namespace storey::runtime {

class BlockedTerminationSignals {
 public:
  BlockedTerminationSignals();   // blocks SIGINT and SIGTERM in the calling thread
  ~BlockedTerminationSignals();  // restores the previous mask
  BlockedTerminationSignals(const BlockedTerminationSignals&) = delete;
  BlockedTerminationSignals& operator=(const BlockedTerminationSignals&) = delete;

  // Waits up to timeout_s for SIGINT or SIGTERM; returns the signal, or 0.
  int wait(double timeout_s);
  // The mask that was in force before (for child processes to restore after fork).
  const sigset_t& previousMask() const { return previous_; }

 private:
  sigset_t set_;
  sigset_t previous_;
};

// A process that crashes (SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT) writes the signal and
// its stack to stderr as module(+offset) lines (`addr2line -f -C -e MODULE OFFSET` names
// them), then dies of the same signal, so a launcher still reports it as killed by that
// signal. A shutdown that crashes once in a few hundred runs then says where. Installed
// once per process (runComponents does); not in sanitizer builds, whose reports are better.
void installCrashReport();

}  // namespace storey::runtime
