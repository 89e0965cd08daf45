#include "storey/floor_mapper/conversions.h"

#include <cmath>
#include <stdexcept>

#include "storey/runtime/graph_conversions.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_mapper {

storey_msgs::msg::FloorGraphUpdate toMessage(const floor::FloorGraph& graph, const mapping::GraphUpdate& update,
                                             std::uint32_t sequence_number) {
  storey_msgs::msg::FloorGraphUpdate m;
  m.robot(graph.robot);
  m.floor_graph_id(static_cast<std::uint32_t>(graph.graph_id));
  m.floor_id(graph.floor_id);
  m.floor_height(graph.floor_height);
  m.sequence_number(sequence_number);
  auto pose = [&](const floor::FloorNode& n) {
    storey_msgs::msg::NodePose p;
    p.floor_graph_id(static_cast<std::uint32_t>(graph.graph_id));
    p.node_id(static_cast<std::uint32_t>(n.id));
    p.x(n.pose.x());
    p.y(n.pose.y());
    p.theta(n.pose.theta());
    return p;
  };
  const auto graph_id = static_cast<std::uint32_t>(graph.graph_id);
  for (const auto& n : update.new_nodes) m.new_nodes().push_back(runtime::toMessage(n, graph_id));
  for (const auto& e : update.new_edges) m.new_edges().push_back(runtime::toMessage(e));
  if (update.poses_changed) {
    for (const auto& n : graph.nodes) m.optimized_poses().push_back(pose(n));
  } else {
    // New nodes may have moved since they were taken (a loop closure in the same step).
    for (const auto& n : update.new_nodes)
      if (const floor::FloorNode* current = graph.findNode(n.id)) m.optimized_poses().push_back(pose(*current));
  }
  return m;
}

}  // namespace storey::floor_mapper
