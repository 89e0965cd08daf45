#include "storey/runtime/executor.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <stdexcept>

#include "storey/common/log.h"

namespace storey::runtime {

Executor::Executor(int threads) {
  if (threads < 1) throw std::invalid_argument("Executor needs at least one worker thread");
  // The ids are recorded before any task can run (nothing is queued yet), so
  // onWorkerThread() reads them without a lock.
  for (int i = 0; i < threads; ++i) {
    workers_.emplace_back([this] { workerLoop(); });
    worker_ids_.push_back(workers_.back().get_id());
  }
  timer_thread_ = std::thread([this] { timerLoop(); });
}

Executor::~Executor() { shutdown(); }

bool Executor::post(Task task) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return false;
    queue_.push_back(std::move(task));
  }
  work_cv_.notify_one();
  return true;
}

namespace {

// The hand-over between invoke() and the worker that runs its task. The worker moves
// a failure in here and keeps no reference to it, so the exception is destroyed on
// the calling thread. (With std::promise the worker could drop the last reference; the
// reference count lives in the uninstrumented libstdc++ and ThreadSanitizer then
// reports the exception's message being freed under the caller's reads.)
struct Invocation {
  std::mutex mutex;
  std::condition_variable cv;
  bool finished = false;
  bool ran = false;
  std::exception_ptr failure;
};

// Owned by the queued task. If shutdown() drops the task unrun, the destructor tells
// the caller, which would otherwise wait forever.
class InvocationTicket {
 public:
  explicit InvocationTicket(std::shared_ptr<Invocation> invocation)
      : invocation_(std::move(invocation)) {}
  InvocationTicket(const InvocationTicket&) = delete;
  InvocationTicket& operator=(const InvocationTicket&) = delete;
  ~InvocationTicket() { finish(false, nullptr); }

  void finish(bool ran, std::exception_ptr failure) {
    std::lock_guard<std::mutex> lock(invocation_->mutex);
    if (invocation_->finished) return;
    invocation_->finished = true;
    invocation_->ran = ran;
    invocation_->failure = std::move(failure);
    invocation_->cv.notify_all();
  }

 private:
  std::shared_ptr<Invocation> invocation_;
};

}  // namespace

void Executor::invoke(const Task& task) {
  if (onWorkerThread()) return task();
  auto invocation = std::make_shared<Invocation>();
  auto ticket = std::make_shared<InvocationTicket>(invocation);
  const bool queued = post([&task, ticket] {
    std::exception_ptr failure;
    try {
      task();
    } catch (...) {
      failure = std::current_exception();
    }
    ticket->finish(true, std::move(failure));
  });
  ticket.reset();  // the queued task is its only owner now: dropping it tells us
  if (!queued) return task();
  std::exception_ptr failure;
  {
    std::unique_lock<std::mutex> lock(invocation->mutex);
    invocation->cv.wait(lock, [&] { return invocation->finished; });
    if (!invocation->ran) {
      throw std::runtime_error("executor: shut down before an invoked task could run");
    }
    failure = std::move(invocation->failure);
  }
  if (failure) std::rethrow_exception(std::move(failure));
}

Executor::TimerId Executor::addTimer(double period_s, Task callback) {
  if (!(period_s > 0.0)) throw std::invalid_argument("timer period must be positive");
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(period_s));
  TimerId id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    id = next_timer_id_++;
    timers_[id] = Timer{period, std::chrono::steady_clock::now() + period,
                        std::make_shared<Task>(std::move(callback)), std::make_shared<bool>(false)};
  }
  timer_cv_.notify_all();
  return id;
}

void Executor::cancelTimer(TimerId id) {
  std::lock_guard<std::mutex> lock(mutex_);
  timers_.erase(id);
}

void Executor::shutdown() {
  std::lock_guard<std::mutex> serial(shutdown_mutex_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    queue_.clear();
    timers_.clear();
  }
  work_cv_.notify_all();
  timer_cv_.notify_all();
  if (timer_thread_.joinable()) timer_thread_.join();
  for (auto& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
}

bool Executor::isShutDown() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stopping_;
}

bool Executor::onWorkerThread() const {
  const auto self = std::this_thread::get_id();
  return std::find(worker_ids_.begin(), worker_ids_.end(), self) != worker_ids_.end();
}

void Executor::drain() {
  if (onWorkerThread()) return;  // a worker cannot wait for the queue it is draining
  std::mutex done_mutex;
  std::condition_variable done_cv;
  bool done = false;
  // With several workers, one marker per worker guarantees all earlier tasks started;
  // one worker (the usual case) gives the stronger "all finished".
  post([&] {
    std::lock_guard<std::mutex> lock(done_mutex);
    done = true;
    done_cv.notify_all();
  });
  std::unique_lock<std::mutex> lock(done_mutex);
  done_cv.wait_for(lock, std::chrono::seconds(30), [&] { return done || isShutDown(); });
}

void Executor::runTask(const Task& task) {
  try {
    task();
  } catch (const std::exception& e) {
    common::logError(common::str("executor: callback failed: ", e.what()));
  } catch (...) {
    common::logError("executor: callback failed with an unknown exception");
  }
}

void Executor::workerLoop() {
  for (;;) {
    Task task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      work_cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    runTask(task);
  }
}

void Executor::timerLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (timers_.empty()) {
      timer_cv_.wait(lock);
      continue;
    }
    auto next = std::min_element(timers_.begin(), timers_.end(), [](const auto& a, const auto& b) {
      return a.second.next < b.second.next;
    });
    const auto deadline = next->second.next;
    if (std::chrono::steady_clock::now() < deadline) {
      timer_cv_.wait_until(lock, deadline);
      continue;  // timers may have changed while waiting
    }
    Timer& timer = next->second;
    // Keep the schedule on the original grid; after a long stall, jump ahead.
    timer.next += timer.period;
    const auto now = std::chrono::steady_clock::now();
    if (timer.next < now) timer.next = now + timer.period;
    if (*timer.queued) continue;
    *timer.queued = true;
    const TimerId id = next->first;
    std::shared_ptr<Task> callback = timer.callback;
    std::shared_ptr<bool> queued = timer.queued;
    queue_.push_back([this, id, callback, queued] {
      {
        std::lock_guard<std::mutex> guard(mutex_);
        *queued = false;
        if (timers_.find(id) == timers_.end()) return;  // cancelled while queued
      }
      (*callback)();
    });
    work_cv_.notify_one();
  }
}

}  // namespace storey::runtime
