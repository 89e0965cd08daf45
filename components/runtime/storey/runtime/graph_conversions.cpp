#include "storey/runtime/graph_conversions.h"

#include <array>
#include <cmath>
#include <stdexcept>

#include "storey/runtime/sensor_conversions.h"

namespace storey::runtime {

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

storey_msgs::msg::FloorGraphNode toMessage(const floor::FloorNode& n, std::uint32_t graph_id) {
  storey_msgs::msg::FloorGraphNode node;
  node.node_id(static_cast<std::uint32_t>(n.id));
  node.floor_graph_id(graph_id);
  node.stamp(toTimeMessage(n.stamp));
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
  node.odom_x(n.odometry.x());
  node.odom_y(n.odometry.y());
  node.odom_theta(n.odometry.theta());
  return node;
}

storey_msgs::msg::FloorGraphEdge toMessage(const floor::FloorEdge& e) {
  storey_msgs::msg::FloorGraphEdge edge;
  edge.from_node(static_cast<std::uint32_t>(e.from));
  edge.to_node(static_cast<std::uint32_t>(e.to));
  edge.dx(e.measurement.x());
  edge.dy(e.measurement.y());
  edge.dtheta(e.measurement.theta());
  edge.information(informationToMessage(e.information));
  edge.kind(edgeKind(e.kind));
  return edge;
}

std::array<double, 9> informationToMessage(const Eigen::Matrix3d& information) {
  std::array<double, 9> values{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) values[static_cast<std::size_t>(r * 3 + c)] = information(r, c);
  return values;
}

Eigen::Matrix3d informationFromMessage(const std::array<double, 9>& values) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = values[static_cast<std::size_t>(r * 3 + c)];
  return m;
}

void requireFinite(double value, const std::string& field) {
  if (!std::isfinite(value)) throw std::invalid_argument(field + " is not finite");
}

floor::FloorNode fromMessage(const storey_msgs::msg::FloorGraphNode& n, const std::string& where) {
  const std::string at = where + ": node " + std::to_string(n.node_id());
  requireFinite(n.x(), at + ".x");
  requireFinite(n.y(), at + ".y");
  requireFinite(n.theta(), at + ".theta");
  requireFinite(n.sensor_x(), at + ".sensor_x");
  requireFinite(n.sensor_y(), at + ".sensor_y");
  requireFinite(n.sensor_theta(), at + ".sensor_theta");
  requireFinite(n.odom_x(), at + ".odom_x");
  requireFinite(n.odom_y(), at + ".odom_y");
  requireFinite(n.odom_theta(), at + ".odom_theta");
  floor::FloorNode node;
  node.id = static_cast<int>(n.node_id());
  node.stamp = fromTimeMessage(n.stamp());
  node.pose = geometry::Pose2(n.x(), n.y(), n.theta());
  node.first_pose = node.pose;  // a node is sent with its pose once, when it is new
  node.odometry = geometry::Pose2(n.odom_x(), n.odom_y(), n.odom_theta());
  node.scan.stamp = node.stamp;
  node.scan.angle_min = n.angle_min();
  node.scan.angle_increment = n.angle_increment();
  node.scan.range_min = n.range_min();
  node.scan.range_max = n.range_max();
  node.scan.ranges = n.ranges();
  node.scan.sensor_offset = geometry::Pose2(n.sensor_x(), n.sensor_y(), n.sensor_theta());
  const std::string problem = node.scan.validate();
  if (!problem.empty()) throw std::invalid_argument(at + ": " + problem);
  return node;
}

}  // namespace storey::runtime
