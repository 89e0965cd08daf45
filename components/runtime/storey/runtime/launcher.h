// `storey launch`: runs a bringup file's processes, either all in this process or as one
// child process each (re-executing a storey binary with `component --bringup FILE
// --process NAME`). The launcher forwards SIGINT/SIGTERM to its children, shuts the
// deployment down when any child ends, and reports a child that failed.
#pragma once

#include <string>
#include <vector>

#include "storey/runtime/bringup.h"
#include "storey/runtime/component_registry.h"
#include "storey/runtime/runner.h"

namespace storey::runtime {

struct LaunchOptions {
  double duration_s = 0.0;         // > 0: stop the deployment after this many seconds
  double shutdown_timeout_s = 10;  // after SIGTERM, children get this long before SIGKILL
  std::string qos_profiles_file;
};

// How to start a child: argv = executable, leading_args..., "--bringup", FILE,
// "--process", NAME.
struct ChildCommand {
  std::string executable;
  std::vector<std::string> leading_args;
};

// The path of the running executable (/proc/self/exe).
std::string currentExecutable();

// All components of all processes in one process and one Context. Every process must use
// the same domain id (throws otherwise).
int launchSingleProcess(const Bringup& bringup, const ComponentRegistry& registry,
                        const LaunchOptions& options);

// One child per process. Returns 0 when the deployment was stopped (signal, time limit)
// or a child finished cleanly, 1 when a child failed (its name and exit code or signal
// are logged as errors).
int launchProcesses(const Bringup& bringup, const ChildCommand& child,
                    const LaunchOptions& options);

// The child side: runs process `name` of the bringup.
int runBringupProcess(const Bringup& bringup, const std::string& name,
                      const ComponentRegistry& registry, const LaunchOptions& options);

}  // namespace storey::runtime
