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

std::shared_ptr<const std::vector<Eigen::Vector2d>> LaserScan::beamDirections() const {
  struct Cached {
    double angle_min = 0.0, angle_increment = 0.0;
    std::size_t size = 0;
    std::shared_ptr<const std::vector<Eigen::Vector2d>> directions;
  };
  thread_local Cached cached;
  if (!cached.directions || cached.angle_min != angle_min || cached.angle_increment != angle_increment ||
      cached.size != ranges.size()) {
    auto directions = std::make_shared<std::vector<Eigen::Vector2d>>(ranges.size());
    for (std::size_t i = 0; i < ranges.size(); ++i) {
      const double a = angle(i);
      (*directions)[i] = Eigen::Vector2d(std::cos(a), std::sin(a));
    }
    cached = {angle_min, angle_increment, ranges.size(), std::move(directions)};
  }
  return cached.directions;
}

std::vector<Eigen::Vector2d> LaserScan::pointsInRobotFrame() const {
  std::vector<Eigen::Vector2d> points;
  points.reserve(ranges.size());
  const auto directions = beamDirections();
  for (std::size_t i = 0; i < ranges.size(); ++i)
    if (isReturn(i)) points.push_back(static_cast<double>(ranges[i]) * (*directions)[i]);
  sensor_offset.transformPoints(points, &points);
  return points;
}

std::vector<Eigen::Vector2d> LaserScan::pointsInWorld(const geometry::Pose2& robot_pose) const {
  std::vector<Eigen::Vector2d> points = pointsInRobotFrame();
  robot_pose.transformPoints(points, &points);
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
