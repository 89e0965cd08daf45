// The building/scenario YAML loader (storey::sim loadScenarioString) on arbitrary text,
// with the shipped robot models.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "storey/common/log.h"
#include "storey/sim/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  storey::common::setLogLevel(storey::common::LogLevel::kSilent);
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)storey::sim::loadScenarioString(text, "fuzz.yaml", STOREY_SOURCE_DIR "/config/robots");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
