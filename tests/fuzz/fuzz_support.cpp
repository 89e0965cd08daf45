#include "fuzz_support.h"

#include <cstdlib>
#include <stdexcept>

namespace storey::fuzz {

std::string fuzzTempDir() {
  static const std::string dir = [] {
    char pattern[] = "/tmp/storey-fuzz-XXXXXX";
    if (!mkdtemp(pattern)) throw std::runtime_error("cannot create a temporary folder");
    return std::string(pattern);
  }();
  return dir;
}

}  // namespace storey::fuzz
