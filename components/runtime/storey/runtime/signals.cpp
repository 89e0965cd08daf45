#include "storey/runtime/signals.h"

#include <pthread.h>

#include <cerrno>
#include <cmath>
#include <ctime>

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

}  // namespace storey::runtime
