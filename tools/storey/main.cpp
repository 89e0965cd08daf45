// storey: maps multistory buildings. `storey <command> --help` describes each command.
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "args.h"
#include "commands.inc"
#include "storey/common/config.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

void printCommands() {
  std::cout << "usage: storey <command> [arguments]\n\ncommands:\n";
  for (const auto& entry : storey::cli::kCommands) {
    std::string name = entry.name;
    std::cout << "  " << name << std::string(name.size() < 12 ? 12 - name.size() : 1, ' ')
              << entry.summary << "\n";
  }
  std::cout << "\n`storey <command> --help` describes a command.\n";
}

// Every match target (tracking map, loop-closure candidate map, successor map) allocates and
// frees grids of megabytes. With glibc's defaults the freed memory goes back to the kernel
// (grids above the mmap threshold are unmapped, and the heap's top is trimmed) and the next
// target faults it in again page by page: a tenth of a front-end run on intel went into
// page faults. Served from the heap and kept there, it is reused; the process keeps what it
// has needed at its peak (infinite-corridor: 457-470 MB instead of 409 MB).
void keepFreedMemory() {
#if defined(__GLIBC__)
  // No allocation gets its own mapping: 32 MB, glibc's largest mmap threshold, is below
  // infinite-corridor's closure maps.
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  keepFreedMemory();
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") ||
      !std::strcmp(argv[1], "help")) {
    printCommands();
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  for (const auto& entry : storey::cli::kCommands) {
    if (command != entry.name) continue;
    storey::cli::Args args(command, std::vector<std::string>(argv + 2, argv + argc));
    try {
      return entry.run(args);
    } catch (const storey::cli::UsageError& e) {
      std::cerr << "storey " << command << ": " << e.what() << "\n";
      return 2;
    } catch (const std::exception& e) {
      std::cerr << "storey " << command << ": error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "storey: unknown command '" << command << "'\n";
  printCommands();
  return 2;
}
