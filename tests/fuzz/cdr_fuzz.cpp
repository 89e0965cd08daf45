// CDR decoding of storey_msgs (storey::runtime deserializeCdr) for FloorGraphUpdate and
// InterFloorConstraint: raw bytes, or a valid serialized message patched by the input.
#include <cstdint>
#include <vector>

#include "fuzz_support.h"
#include "storey/runtime/bag_cdr.h"
#include "storey_msgs/msg/FloorGraphUpdate.h"
#include "storey_msgs/msg/InterFloorConstraint.h"

namespace {

std::vector<std::uint8_t> sampleUpdate() {
  storey_msgs::msg::FloorGraphUpdate update;
  update.robot("robot1");
  update.floor_graph_id(1);
  update.floor_id(2);
  update.floor_height(3.0);
  update.sequence_number(4);
  for (std::uint32_t i = 0; i < 2; ++i) {
    storey_msgs::msg::FloorGraphNode node;
    node.node_id(i);
    node.floor_graph_id(1);
    node.x(i);
    node.ranges({1.0f, 2.0f, 3.0f, 4.0f});
    update.new_nodes().push_back(node);
    storey_msgs::msg::NodePose pose;
    pose.node_id(i);
    update.optimized_poses().push_back(pose);
  }
  storey_msgs::msg::FloorGraphEdge edge;
  edge.from_node(0);
  edge.to_node(1);
  update.new_edges().push_back(edge);
  return storey::runtime::serializeCdr(update);
}

std::vector<std::uint8_t> sampleConstraint() {
  storey_msgs::msg::InterFloorConstraint constraint;
  constraint.constraint_id(1);
  constraint.to_floor_graph(2);
  constraint.dz(3.0);
  return storey::runtime::serializeCdr(constraint);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::uint8_t> update_sample = sampleUpdate();
  static const std::vector<std::uint8_t> constraint_sample = sampleConstraint();
  const bool constraint = size > 0 && (data[0] & 2);
  std::vector<std::uint8_t> bytes;
  if (size > 0 && (data[0] & 1)) {
    bytes = storey::fuzz::patchSample(constraint ? constraint_sample : update_sample, data + 1,
                                      size - 1);
  } else {
    bytes.assign(data, data + size);
  }
  try {
    if (constraint) {
      storey_msgs::msg::InterFloorConstraint message;
      storey::runtime::deserializeCdr(bytes.data(), bytes.size(), message, "InterFloorConstraint");
    } else {
      storey_msgs::msg::FloorGraphUpdate message;
      storey::runtime::deserializeCdr(bytes.data(), bytes.size(), message, "FloorGraphUpdate");
    }
  } catch (const storey::runtime::CdrError&) {
  }
  return 0;
}
