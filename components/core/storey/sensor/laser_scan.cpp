#include "storey/sensor/laser_scan.h"

#include <cmath>
#include <sstream>

namespace storey::sensor {

bool LaserScan::isReturn(std::size_t i) const {
  const float r = ranges[i];
  return std::isfinite(r) && r >= range_min && r < range_max;
}

std::size_t LaserScan::countReturns() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < ranges.size(); ++i) n += isReturn(i);
  return n;
}

std::vector<Eigen::Vector2d> LaserScan::pointsInRobotFrame() const {
  std::vector<Eigen::Vector2d> points;
  points.reserve(ranges.size());
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    if (!isReturn(i)) continue;
    const double a = angle(i);
    points.push_back(sensor_offset.transformPoint({ranges[i] * std::cos(a), ranges[i] * std::sin(a)}));
  }
  return points;
}

std::vector<Eigen::Vector2d> LaserScan::pointsInWorld(const geometry::Pose2& robot_pose) const {
  std::vector<Eigen::Vector2d> points = pointsInRobotFrame();
  for (auto& p : points) p = robot_pose.transformPoint(p);
  return points;
}

std::string LaserScan::validate() const {
  std::ostringstream why;
  if (ranges.empty()) why << "scan has no beams";
  else if (!std::isfinite(angle_min) || !std::isfinite(angle_increment) || angle_increment == 0.0)
    why << "scan has invalid angles (angle_min " << angle_min << ", increment " << angle_increment << ")";
  else if (!(range_max > range_min) || !(range_min >= 0.0) || !std::isfinite(range_max))
    why << "scan has invalid range limits [" << range_min << ", " << range_max << "]";
  else if (!sensor_offset.isFinite())
    why << "scan has a non-finite sensor offset";
  return why.str();
}

LaserScan subsample(const LaserScan& scan, std::size_t step) {
  LaserScan out = scan;
  if (step <= 1) return out;
  out.ranges.clear();
  for (std::size_t i = 0; i < scan.ranges.size(); i += step) out.ranges.push_back(scan.ranges[i]);
  out.angle_increment = scan.angle_increment * static_cast<double>(step);
  return out;
}

}  // namespace storey::sensor
