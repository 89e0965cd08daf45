// `storey component`: runs components in this process. `storey launch` starts one of
// these per bringup process; it also runs a single component by hand.
#include <iostream>

#include "args.h"
#include "storey/catalog/all_components.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/launcher.h"
#include "storey/runtime/runner.h"

namespace storey::cli {

extern const char* const summary_component =
    "run components in this process (one bringup process, or one component)";

int run_component(Args& args) {
  args.usage("(--bringup FILE --process NAME | --kind KIND --name NAME [--parameters FILE])",
             "Runs components in this process until SIGINT/SIGTERM, a component finishes, or\n"
             "--duration passes. `storey launch` runs one of these per bringup process.")
      .option("bringup", "FILE", "bringup file (with --process)")
      .option("process", "NAME", "process of the bringup file to run")
      .option("kind", "KIND", "component kind to run alone (see --list)")
      .option("name", "NAME", "component name (with --kind)")
      .option("parameters", "FILE", "component parameter file (with --kind)")
      .option("domain", "ID", "DDS domain id (default: the bringup's, else ROS_DOMAIN_ID, else 0)")
      .option("duration", "SECONDS", "stop after this long (0: run until stopped)", "0")
      .flag("list", "list the component kinds and exit");
  if (!args.parse()) return 0;
  runtime::ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  if (args.flagSet("list")) {
    for (const auto& kind : registry.kinds()) {
      std::cout << kind << "  " << registry.summary(kind) << "\n";
    }
    return 0;
  }
  const double duration = args.getDouble("duration");
  if (duration < 0) throw UsageError("--duration must not be negative");
  const int domain = args.has("domain") ? static_cast<int>(args.getInt("domain")) : -1;
  if (args.has("domain") && (domain < 0 || domain > 232)) {
    throw UsageError("--domain must be in [0, 232]");
  }
  if (args.has("bringup") || args.has("process")) {
    if (!args.has("bringup") || !args.has("process")) {
      throw UsageError("--bringup and --process go together");
    }
    if (args.has("kind")) throw UsageError("--kind does not go with --bringup");
    const auto bringup = runtime::readBringup(args.get("bringup"), registry);
    runtime::LaunchOptions options;
    options.duration_s = duration;
    if (domain >= 0) {
      auto copy = bringup;
      for (auto& process : copy.processes) process.domain_id = domain;
      return runtime::runBringupProcess(copy, args.get("process"), registry, options);
    }
    return runtime::runBringupProcess(bringup, args.get("process"), registry, options);
  }
  if (!args.has("kind") || !args.has("name")) {
    throw UsageError("give --bringup and --process, or --kind and --name (see --help)");
  }
  runtime::ComponentSpec spec;
  spec.kind = args.get("kind");
  spec.name = args.get("name");
  spec.parameters_file = args.has("parameters") ? args.get("parameters") : "";
  if (!registry.has(spec.kind)) {
    throw UsageError("unknown component kind '" + spec.kind + "' (known: " + registry.kindList() +
                     ")");
  }
  runtime::RunOptions options;
  options.domain_id = domain;
  options.duration_s = duration;
  options.participant_name = spec.name;
  return runtime::runComponents({spec}, registry, options);
}

}  // namespace storey::cli
