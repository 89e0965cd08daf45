// The CARMEN log reader (storey::io), strict and lenient, on arbitrary text. A clean error
// is a CarmenError (or another std::runtime_error); anything else is a finding.
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>

#include "fuzz_support.h"
#include "storey/common/log.h"
#include "storey/io/carmen.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  storey::common::setLogLevel(storey::common::LogLevel::kSilent);
  const std::string path = storey::fuzz::fuzzTempDir() + "/log.txt";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  for (const bool strict : {true, false}) {
    storey::io::CarmenReaderOptions options;
    options.strict = strict;
    try {
      storey::io::CarmenReader reader(path, options);
      storey::io::CarmenRecord record;
      while (reader.next(&record)) {
      }
      (void)reader.stats().summary();
    } catch (const std::runtime_error&) {
    }
  }
  return 0;
}
