#include "storey/eval/corridors.h"

#include <filesystem>

#include "storey/common/config.h"

namespace storey::eval {

std::vector<CorridorSpec> readCorridors(const std::string& path) {
  std::vector<CorridorSpec> corridors;
  if (!std::filesystem::is_regular_file(path)) return corridors;
  const auto root = common::ConfigNode::loadFile(path);
  for (const auto& node : root.sequence("corridors")) {
    CorridorSpec c;
    c.name = node.get<std::string>("name");
    c.floor = node.get<std::string>("floor");
    const auto from = node.getDoubles("from"), to = node.getDoubles("to");
    if (from.size() != 2) node.fail("from", "expected [x, y]");
    if (to.size() != 2) node.fail("to", "expected [x, y]");
    c.from = {from[0], from[1]};
    c.to = {to[0], to[1]};
    node.finish();
    corridors.push_back(c);
  }
  root.finish();
  return corridors;
}

}  // namespace storey::eval
