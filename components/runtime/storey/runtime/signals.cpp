#include "storey/runtime/signals.h"

#include <execinfo.h>
#include <pthread.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <initializer_list>

namespace storey::runtime {

BlockedTerminationSignals::BlockedTerminationSignals() {
  sigemptyset(&set_);
  sigaddset(&set_, SIGINT);
  sigaddset(&set_, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set_, &previous_);
}

BlockedTerminationSignals::~BlockedTerminationSignals() {
  pthread_sigmask(SIG_SETMASK, &previous_, nullptr);
}

int BlockedTerminationSignals::wait(double timeout_s) {
  timespec timeout;
  timeout.tv_sec = static_cast<time_t>(std::floor(timeout_s));
  timeout.tv_nsec = static_cast<long>((timeout_s - std::floor(timeout_s)) * 1e9);
  const int signal = sigtimedwait(&set_, nullptr, &timeout);
  return signal > 0 ? signal : 0;  // EAGAIN (timeout) or EINTR
}

namespace {

void writeAll(const char* text) {
  // Only async-signal-safe calls in the handler: write(2), backtrace_symbols_fd.
  ssize_t unused = ::write(STDERR_FILENO, text, std::strlen(text));
  (void)unused;
}

void reportCrash(int signal) {
  writeAll("[fatal] ");
  writeAll(signal == SIGSEGV  ? "SIGSEGV"
           : signal == SIGBUS ? "SIGBUS"
           : signal == SIGFPE ? "SIGFPE"
           : signal == SIGILL ? "SIGILL"
                              : "SIGABRT");
  writeAll(": stack follows\n");
  void* frames[64];
  const int count = backtrace(frames, 64);
  backtrace_symbols_fd(frames, count, STDERR_FILENO);
  // SA_RESETHAND restored the default action: the process dies of the same signal.
  raise(signal);
}

}  // namespace

void installCrashReport() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  return;
#else
  static const bool installed = [] {
    // backtrace() loads libgcc on first use, which allocates: do it now, not in a crash.
    void* frame[1];
    backtrace(frame, 1);
    struct sigaction action;
    std::memset(&action, 0, sizeof(action));
    action.sa_handler = reportCrash;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND | SA_NODEFER;
    for (int signal : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT})
      sigaction(signal, &action, nullptr);
    return true;
  }();
  (void)installed;
#endif
}

}  // namespace storey::runtime
