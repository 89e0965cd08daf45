#include "storey/floor_mapper/conversions.h"

#include <cmath>
#include <stdexcept>

#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_mapper {

namespace {
std::uint8_t edgeKind(floor::EdgeKind kind) {
  switch (kind) {
    case floor::EdgeKind::kOdometry: return storey_msgs::msg::FloorGraphEdge_Constants::KIND_ODOMETRY;
    case floor::EdgeKind::kScanMatch: return storey_msgs::msg::FloorGraphEdge_Constants::KIND_SCAN_MATCH;
    case floor::EdgeKind::kLoopClosure: return storey_msgs::msg::FloorGraphEdge_Constants::KIND_LOOP_CLOSURE;
  }
  return storey_msgs::msg::FloorGraphEdge_Constants::KIND_ODOMETRY;
}
}  // namespace

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
  for (const auto& n : update.new_nodes) {
    storey_msgs::msg::FloorGraphNode node;
    node.node_id(static_cast<std::uint32_t>(n.id));
    node.floor_graph_id(static_cast<std::uint32_t>(graph.graph_id));
    node.stamp(runtime::toTimeMessage(n.stamp));
    node.x(n.pose.x());
    node.y(n.pose.y());
    node.theta(n.pose.theta());
    node.angle_min(static_cast<float>(n.scan.angle_min));
    node.angle_increment(static_cast<float>(n.scan.angle_increment));
    node.range_min(static_cast<float>(n.scan.range_min));
    node.range_max(static_cast<float>(n.scan.range_max));
    node.ranges(n.scan.ranges);
    node.sensor_x(n.scan.sensor_offset.x());
    node.sensor_y(n.scan.sensor_offset.y());
    node.sensor_theta(n.scan.sensor_offset.theta());
    m.new_nodes().push_back(std::move(node));
  }
  for (const auto& e : update.new_edges) {
    storey_msgs::msg::FloorGraphEdge edge;
    edge.from_node(static_cast<std::uint32_t>(e.from));
    edge.to_node(static_cast<std::uint32_t>(e.to));
    edge.dx(e.measurement.x());
    edge.dy(e.measurement.y());
    edge.dtheta(e.measurement.theta());
    std::array<double, 9> info{};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) info[r * 3 + c] = e.information(r, c);
    edge.information(info);
    edge.kind(edgeKind(e.kind));
    m.new_edges().push_back(std::move(edge));
  }
  if (update.poses_changed) {
    for (const auto& n : graph.nodes) m.optimized_poses().push_back(pose(n));
  } else {
    // New nodes may have moved since they were taken (a loop closure in the same step).
    for (const auto& n : update.new_nodes)
      if (const floor::FloorNode* current = graph.findNode(n.id)) m.optimized_poses().push_back(pose(*current));
  }
  return m;
}

FloorEventInfo fromMessage(const storey_msgs::msg::FloorEvent& message) {
  FloorEventInfo info;
  if (message.kind() == storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_STARTED) {
    info.transit_started = true;
  } else if (message.kind() != storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_ENDED) {
    throw std::invalid_argument("floor event of unknown kind " + std::to_string(message.kind()));
  }
  info.floor_id = message.floor_id();
  info.floor_height = message.floor_height();
  if (!info.transit_started && !std::isfinite(info.floor_height))
    throw std::invalid_argument("floor event with a non-finite floor height");
  return info;
}

}  // namespace storey::floor_mapper
