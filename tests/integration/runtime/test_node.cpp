// Child-process entry point for the runtime's integration tests: the storey binary's
// `component` and `launch` subcommands, with the test component kinds.
//   runtime_test_node --bringup FILE --process NAME
//   runtime_test_node launch FILE [duration_s]
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include "storey/runtime/launcher.h"
#include "test_components.h"

int main(int argc, char** argv) {
  using namespace storey::runtime;
  try {
    ComponentRegistry registry;
    test::registerTestComponents(registry);
    const std::string first = argc > 1 ? argv[1] : "";
    if (first == "launch" && argc >= 3) {
      LaunchOptions options;
      if (argc >= 4) options.duration_s = std::atof(argv[3]);
      const Bringup bringup = readBringup(argv[2], registry);
      return launchProcesses(bringup, ChildCommand{currentExecutable(), {}}, options);
    }
    if (argc == 5 && first == "--bringup" && std::string(argv[3]) == "--process") {
      return runBringupProcess(readBringup(argv[2], registry), argv[4], registry, {});
    }
    std::cerr << "usage: runtime_test_node (--bringup FILE --process NAME | launch FILE [S])\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "runtime_test_node: error: " << e.what() << "\n";
    return 1;
  }
}
