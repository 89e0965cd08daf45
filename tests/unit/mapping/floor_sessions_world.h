// A robot driving through synthetic floors and riding between them, for the floor
// sessions tests: its scans and odometry go to FloorSessions.
#pragma once

#include <cmath>
#include <vector>

#include "storey/mapping/floor_sessions.h"
#include "synthetic_world.h"

namespace storey::mapping::test {

using geometry::Pose2;

inline std::vector<Pose2> legs(const std::vector<Eigen::Vector2d>& waypoints, double heading0,
                               double step = 0.2) {
  std::vector<Pose2> poses;
  double heading = heading0;
  for (std::size_t i = 0; i + 1 < waypoints.size(); ++i) {
    const Eigen::Vector2d d = waypoints[i + 1] - waypoints[i];
    const double next = std::atan2(d.y(), d.x());
    const double turn = geometry::angleDiff(next, heading);
    for (int k = 1; k <= 4; ++k)
      poses.emplace_back(waypoints[i].x(), waypoints[i].y(), heading + turn * k / 4);
    heading = next;
    const int n = static_cast<int>(std::ceil(d.norm() / step));
    for (int k = 1; k <= n; ++k)
      poses.emplace_back(waypoints[i].x() + d.x() * k / n, waypoints[i].y() + d.y() * k / n,
                         heading);
  }
  return poses;
}

struct Robot {
  FloorSessions sessions;
  Pose2 odometry, truth;
  double t = 0.0;
  Robot(const FloorSlamOptions& o, const Pose2& start)
      : sessions(o, "robot", 0, 0.0), truth(start) {}
  std::vector<ScanResult> drive(const World& world, const std::vector<Pose2>& poses) {
    std::vector<ScanResult> results;
    for (const auto& p : poses) {
      odometry = odometry * truth.between(p);
      truth = p;
      results.push_back(sessions.addScan(world.scan(p, t += 0.1), odometry));
    }
    return results;
  }
  // A ride: the odometry goes on (the robot turns and moves in the cabin/stairs).
  void ride(int floor, double height, const Pose2& arrival) {
    sessions.beginTransit();
    arriveAt(arrival);
    sessions.endTransit(floor, height, t);
  }
  // Out of the cabin at `arrival` (on the floor reached), whether or not it is decided.
  void arriveAt(const Pose2& arrival) {
    odometry = odometry * Pose2(0.3, 0.1, 1.0);
    truth = arrival;
  }
};

// Office with a corridor-like north part: asymmetric, 16 m x 10 m.
inline World asymmetricFloor() {
  World w;
  w.addBox(0, 0, 16, 10);
  w.addWall(0, 6, 5, 6);
  w.addWall(6.5, 6, 16, 6);
  w.addWall(5, 0, 5, 3.5);
  w.addWall(10, 0, 10, 2.5);
  w.addBox(2, 1.5, 3, 2.3);
  w.addBox(12, 7.5, 13.5, 8.2);
  w.addBox(7, 3, 7.6, 3.6);
  return w;
}

// Symmetric under a 180 degree turn about (8, 5): a robot seeing part of it cannot tell
// which half it is in.
inline World symmetricFloor() {
  World w;
  w.addBox(0, 0, 16, 10);
  w.addWall(0, 6, 5, 6);
  w.addWall(16, 4, 11, 4);
  w.addWall(5, 0, 5, 2.5);
  w.addWall(11, 10, 11, 7.5);
  w.addBox(2, 1.5, 3, 2.3);
  w.addBox(13, 7.7, 14, 8.5);
  return w;
}

inline World upperFloor() {
  World w;
  w.addBox(0, 0, 8, 6);
  w.addBox(3, 2, 3.5, 2.5);
  return w;
}

}  // namespace storey::mapping::test
