#include "storey/runtime/graph_conversions.h"

#include <cmath>
#include <stdexcept>

#include "storey/runtime/sensor_conversions.h"

namespace storey::runtime {

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
  floor::FloorNode node;
  node.id = static_cast<int>(n.node_id());
  node.stamp = fromTimeMessage(n.stamp());
  node.pose = geometry::Pose2(n.x(), n.y(), n.theta());
  node.odometry = node.pose;
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
