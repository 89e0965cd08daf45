#include "storey/runtime/launcher.h"

#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "storey/common/log.h"
#include "storey/runtime/signals.h"

namespace storey::runtime {
namespace {

struct Child {
  std::string name;
  pid_t pid = -1;
  bool running = false;
  bool ended_on_its_own = false;
  int status = 0;
};

std::string describeExit(int status) {
  if (WIFEXITED(status)) return "exited with code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    return "was killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  return "ended with status " + std::to_string(status);
}

bool failed(int status) { return !WIFEXITED(status) || WEXITSTATUS(status) != 0; }

pid_t spawn(const ChildCommand& command, const std::string& bringup_file,
            const std::string& process, const sigset_t& child_mask) {
  std::vector<std::string> args{command.executable};
  args.insert(args.end(), command.leading_args.begin(), command.leading_args.end());
  args.insert(args.end(), {"--bringup", bringup_file, "--process", process});
  std::vector<char*> argv;
  for (auto& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  // Built before fork: the child of a multithreaded process may only make
  // async-signal-safe calls before exec.
  const std::string message = "storey launch: cannot execute " + command.executable + "\n";
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    pthread_sigmask(SIG_SETMASK, &child_mask, nullptr);
    execv(command.executable.c_str(), argv.data());
    (void)!write(2, message.data(), message.size());
    _exit(127);
  }
  return pid;
}

// Reaps children that ended; returns how many did.
int reap(std::vector<Child>& children) {
  int ended = 0;
  for (auto& child : children) {
    if (!child.running) continue;
    int status = 0;
    if (waitpid(child.pid, &status, WNOHANG) == child.pid) {
      child.running = false;
      child.status = status;
      ++ended;
    }
  }
  return ended;
}

bool anyRunning(const std::vector<Child>& children) {
  for (const auto& child : children) {
    if (child.running) return true;
  }
  return false;
}

void stopAll(std::vector<Child>& children, int signal, double timeout_s) {
  for (const auto& child : children) {
    if (child.running) kill(child.pid, signal);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (anyRunning(children) && std::chrono::steady_clock::now() < deadline) {
    reap(children);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (auto& child : children) {
    if (!child.running) continue;
    common::logWarn(common::str("process '", child.name, "' did not stop within ", timeout_s,
                                " s: killing it"));
    kill(child.pid, SIGKILL);
    waitpid(child.pid, &child.status, 0);
    child.running = false;
  }
}

}  // namespace

std::string currentExecutable() {
  std::error_code error;
  const auto path = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) throw std::runtime_error("cannot find the running executable: " + error.message());
  return path.string();
}

int launchSingleProcess(const Bringup& bringup, const ComponentRegistry& registry,
                        const LaunchOptions& options) {
  std::vector<ComponentSpec> all;
  int domain = -1;
  for (const auto& process : bringup.processes) {
    if (&process != &bringup.processes.front() && process.domain_id != domain) {
      throw std::invalid_argument(bringup.file + ": process '" + process.name +
                                  "' has another domain id than '" +
                                  bringup.processes.front().name +
                                  "'; one process has one domain (run without --single-process)");
    }
    domain = process.domain_id;
    all.insert(all.end(), process.components.begin(), process.components.end());
  }
  RunOptions run;
  run.domain_id = domain;
  run.duration_s = options.duration_s;
  run.qos_profiles_file = options.qos_profiles_file;
  return runComponents(all, registry, run);
}

int runBringupProcess(const Bringup& bringup, const std::string& name,
                      const ComponentRegistry& registry, const LaunchOptions& options) {
  const ProcessSpec& process = bringup.process(name);
  RunOptions run;
  run.domain_id = process.domain_id;
  run.duration_s = options.duration_s;
  run.participant_name = process.name;
  run.qos_profiles_file = options.qos_profiles_file;
  return runComponents(process.components, registry, run);
}

int launchProcesses(const Bringup& bringup, const ChildCommand& command,
                    const LaunchOptions& options) {
  BlockedTerminationSignals blocked;
  const std::string bringup_file = std::filesystem::absolute(bringup.file).string();
  std::vector<Child> children;
  try {
    for (const auto& process : bringup.processes) {
      Child child;
      child.name = process.name;
      child.pid = spawn(command, bringup_file, process.name, blocked.previousMask());
      child.running = true;
      children.push_back(child);
      common::logInfo(common::str("started process '", child.name, "' (pid ", child.pid, ")"));
    }
  } catch (...) {
    stopAll(children, SIGTERM, options.shutdown_timeout_s);
    throw;
  }
  const auto start = std::chrono::steady_clock::now();
  int stop_signal = SIGTERM;
  for (;;) {
    const int signal = blocked.wait(0.05);
    if (signal != 0) {
      common::logInfo(common::str("received ", strsignal(signal), ": stopping all processes"));
      stop_signal = signal;
      break;
    }
    if (reap(children) > 0) break;  // a child that ends on its own ends the deployment
    if (options.duration_s > 0 && std::chrono::steady_clock::now() - start >=
                                      std::chrono::duration<double>(options.duration_s)) {
      break;
    }
  }
  for (auto& child : children) child.ended_on_its_own = !child.running;
  stopAll(children, stop_signal, options.shutdown_timeout_s);
  int result = 0;
  for (const auto& child : children) {
    // Stopped by us: exiting 0 or dying of the signal we sent is a clean stop.
    const bool clean = child.ended_on_its_own
                           ? !failed(child.status)
                           : !failed(child.status) || (WIFSIGNALED(child.status) &&
                                                       WTERMSIG(child.status) == stop_signal);
    if (!clean) {
      common::logError(common::str("process '", child.name, "' (pid ", child.pid, ") ",
                                   describeExit(child.status)));
      result = 1;
    } else if (child.ended_on_its_own) {
      common::logInfo(common::str("process '", child.name, "' finished: stopping the others"));
    }
  }
  return result;
}

}  // namespace storey::runtime
