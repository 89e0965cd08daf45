// `storey launch`: runs a deployment described by a bringup file.
#include "args.h"
#include "storey/catalog/all_components.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/launcher.h"

namespace storey::cli {

extern const char* const summary_launch = "run the components of a bringup file";

int run_launch(Args& args) {
  args.usage("BRINGUP.yaml [--single-process]",
             "Runs the processes of a bringup file: one child process each (default), or all\n"
             "components in this process. Stops on SIGINT/SIGTERM, after --duration, or when a\n"
             "process ends; exits non-zero (naming it) when a process failed.")
      .flag("single-process", "run every component in this process")
      .option("duration", "SECONDS", "stop after this long (0: run until stopped)", "0");
  if (!args.parse()) return 0;
  const std::string file = args.positional(0, "bringup file");
  runtime::LaunchOptions options;
  options.duration_s = args.getDouble("duration");
  if (options.duration_s < 0) throw UsageError("--duration must not be negative");
  runtime::ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  const auto bringup = runtime::readBringup(file, registry);
  if (args.flagSet("single-process")) {
    return runtime::launchSingleProcess(bringup, registry, options);
  }
  runtime::ChildCommand child{runtime::currentExecutable(), {"component"}};
  return runtime::launchProcesses(bringup, child, options);
}

}  // namespace storey::cli
