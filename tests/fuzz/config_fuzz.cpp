// The strict ConfigNode (storey::common) on arbitrary YAML: typed reads of every kind,
// children, sequences and finish().
#include <cstdint>
#include <stdexcept>
#include <string>

#include "storey/common/config.h"

namespace {

void readAll(const storey::common::ConfigNode& node, int depth) {
  using storey::common::ConfigNode;
  if (depth > 4 || !node.isMap()) return;
  (void)node.get<double>("d", 0.0);
  (void)node.get<int>("i", 0);
  (void)node.get<bool>("b", false);
  (void)node.get<std::string>("s", "");
  (void)node.getDouble("r", 0.5, 0.0, 1.0);
  (void)node.getInt("n", 1, 0, 10);
  (void)node.getChoice("c", "a", {"a", "b"});
  if (node.has("v")) (void)node.getDoubles("v");
  if (node.has("m")) readAll(node.child("m"), depth + 1);
  if (node.has("l")) {
    for (const ConfigNode& element : node.sequence("l")) readAll(element, depth + 1);
  }
  node.finish();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    readAll(storey::common::ConfigNode::loadString(text, "fuzz.yaml"), 0);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
