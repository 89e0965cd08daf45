#include <iostream>

#include "args.h"

namespace storey::cli {

extern const char* const summary_version = "print storey's version";

int run_version(Args& args) {
  args.usage("", "Prints the version of storey.");
  if (!args.parse()) return 0;
  std::cout << "storey " << STOREY_VERSION << "\n";
  return 0;
}

}  // namespace storey::cli
