// Runs callbacks (subscription deliveries, timers, posted work) on its own worker
// thread(s), never on DDS listener threads. With one worker (the default) a component's
// callbacks never run concurrently, so components need no locks of their own.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace storey::runtime {

class Executor {
 public:
  using Task = std::function<void()>;
  using TimerId = std::uint64_t;

  explicit Executor(int threads = 1);
  ~Executor();  // shutdown()
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  // Queues a task; returns false (and drops it) after shutdown(). Exceptions from tasks
  // are logged, not fatal.
  bool post(Task task);
  // Runs `task` on a worker and waits for it, rethrowing its exception; runs it directly
  // when called from a worker or after shutdown. A task that shutdown() drops before it
  // ran throws std::runtime_error. Lifecycle transitions use this so that they never
  // overlap a component's callbacks.
  void invoke(const Task& task);
  // Calls `callback` every `period_s` seconds (first call one period from now). A tick
  // that is still queued is not queued twice: slow callbacks skip ticks, never pile up.
  TimerId addTimer(double period_s, Task callback);
  // After it returns, the timer's callback is not started again (a call already running
  // on another worker may still finish).
  void cancelTimer(TimerId id);

  // Stops the timers, lets the workers finish the task they are running, drops queued
  // tasks and joins all threads. Idempotent; must not be called from a task.
  void shutdown();
  bool isShutDown() const;
  // True when the calling thread is one of this executor's workers.
  bool onWorkerThread() const;
  // Blocks until every task queued before the call has run. Returns at once when called
  // from a worker (which cannot wait for its own queue).
  void drain();

 private:
  struct Timer {
    std::chrono::steady_clock::duration period;
    std::chrono::steady_clock::time_point next;
    std::shared_ptr<Task> callback;
    std::shared_ptr<bool> queued;  // guarded by mutex_
  };
  void workerLoop();
  void timerLoop();
  void runTask(const Task& task);

  mutable std::mutex mutex_;
  std::condition_variable work_cv_;
  std::condition_variable timer_cv_;
  std::deque<Task> queue_;
  std::map<TimerId, Timer> timers_;
  TimerId next_timer_id_ = 1;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
  std::vector<std::thread::id> worker_ids_;  // fixed after construction
  std::thread timer_thread_;
  std::mutex shutdown_mutex_;  // serialises shutdown() calls
};

}  // namespace storey::runtime
