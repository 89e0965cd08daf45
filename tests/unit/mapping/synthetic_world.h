// Test fixtures: scans ray-cast in worlds of line segments (rooms, corridors, loops).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping::test {

struct Segment {
  Eigen::Vector2d a, b;
};

struct World {
  std::vector<Segment> walls;

  void addBox(double x0, double y0, double x1, double y1) {
    walls.push_back({{x0, y0}, {x1, y0}});
    walls.push_back({{x1, y0}, {x1, y1}});
    walls.push_back({{x1, y1}, {x0, y1}});
    walls.push_back({{x0, y1}, {x0, y0}});
  }
  void addWall(double x0, double y0, double x1, double y1) { walls.push_back({{x0, y0}, {x1, y1}}); }

  // Distance along the ray from `origin` in direction `angle` to the first wall (inf: none).
  double cast(const Eigen::Vector2d& origin, double angle) const {
    const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
    double best = std::numeric_limits<double>::infinity();
    for (const auto& w : walls) {
      const Eigen::Vector2d e = w.b - w.a;
      const double denom = d.x() * e.y() - d.y() * e.x();
      if (std::abs(denom) < 1e-12) continue;
      const Eigen::Vector2d ao = w.a - origin;
      const double t = (ao.x() * e.y() - ao.y() * e.x()) / denom;
      const double u = (ao.x() * d.y() - ao.y() * d.x()) / denom;
      if (t > 0 && u >= 0 && u <= 1 && t < best) best = t;
    }
    return best;
  }

  sensor::LaserScan scan(const geometry::Pose2& pose, double stamp, int beams = 361,
                         double range_max = 20.0) const {
    sensor::LaserScan s;
    s.stamp = stamp;
    s.angle_min = -M_PI / 2;
    s.angle_increment = M_PI / (beams - 1);
    s.range_min = 0.05;
    s.range_max = range_max;
    for (int i = 0; i < beams; ++i) {
      const double r = cast(pose.translation(), pose.theta() + s.angle(i));
      s.ranges.push_back(r < range_max ? static_cast<float>(r) : std::numeric_limits<float>::infinity());
    }
    return s;
  }
};

// An office-like room with a few obstacles (non-symmetric), 12 m x 8 m.
inline World officeWorld() {
  World w;
  w.addBox(0, 0, 12, 8);
  w.addBox(2, 2, 3, 3.5);
  w.addBox(7, 5, 9.5, 6);
  w.addWall(5, 0, 5, 3);
  w.addWall(9, 2, 12, 2);
  w.addBox(10.5, 6.5, 11, 7);
  return w;
}

// A long featureless corridor: two parallel walls, 2 m apart, 200 m long.
inline World corridorWorld() {
  World w;
  w.addWall(-100, -1, 100, -1);
  w.addWall(-100, 1, 100, 1);
  return w;
}

// A ring corridor around a block: 24 m x 16 m outside, 2 m wide, with a few doors and
// pillars so that it is not featureless (the loop-closure test and the front-end bench).
inline World ringCorridorWorld() {
  World w;
  w.addBox(0, 0, 24, 16);
  w.addBox(2, 2, 22, 14);
  w.addBox(6, 0.05, 6.4, 0.4);
  w.addBox(15, 15.6, 15.5, 15.95);
  w.addBox(23.6, 7, 23.95, 7.4);
  w.addBox(0.05, 10, 0.4, 10.6);
  w.addBox(11, 1.7, 11.5, 2.0);
  return w;
}

// Poses along straight legs between waypoints (turning on the spot at each in three
// steps), `step` apart.
inline std::vector<geometry::Pose2> pathThrough(const std::vector<Eigen::Vector2d>& waypoints, double step = 0.25) {
  std::vector<geometry::Pose2> poses;
  for (std::size_t i = 0; i + 1 < waypoints.size(); ++i) {
    const Eigen::Vector2d d = waypoints[i + 1] - waypoints[i];
    const double heading = std::atan2(d.y(), d.x());
    if (!poses.empty()) {
      const double turn = geometry::angleDiff(heading, poses.back().theta());
      for (int k = 1; k <= 3; ++k)
        poses.emplace_back(waypoints[i].x(), waypoints[i].y(), poses.back().theta() + turn / 3);
    }
    const int n = static_cast<int>(std::ceil(d.norm() / step));
    for (int k = poses.empty() ? 0 : 1; k <= n; ++k)
      poses.emplace_back(waypoints[i].x() + d.x() * k / n, waypoints[i].y() + d.y() * k / n, heading);
  }
  return poses;
}

}  // namespace storey::mapping::test
