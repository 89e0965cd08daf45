// The g2o and TORO readers (storey::graph parseGraph) on arbitrary text.
#include <cstdint>
#include <stdexcept>
#include <string>

#include "storey/graph/graph_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (const auto format : {storey::graph::GraphFormat::kG2o, storey::graph::GraphFormat::kToro}) {
    try {
      storey::graph::GraphReadInfo info;
      storey::graph::PoseGraph graph = storey::graph::parseGraph(text, format, "fuzz", &info);
      // What was accepted must write back out.
      (void)storey::graph::formatGraph(graph, format);
    } catch (const std::runtime_error&) {
    }
  }
  return 0;
}
