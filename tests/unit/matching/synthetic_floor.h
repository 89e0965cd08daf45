// Test-only synthetic floors: walls as segments, a robot driven along waypoints, scans by
// exact ray casting, noisy odometry (seeded). Gives floor graphs with known alignment.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "storey/floor/floor_graph.h"
#include "storey/geometry/pose2.h"

namespace storey::matching::test {

struct Wall {
  Eigen::Vector2d a, b;
};
using Walls = std::vector<Wall>;

inline void addBox(Walls* w, double x0, double y0, double x1, double y1) {
  w->push_back({{x0, y0}, {x1, y0}});
  w->push_back({{x1, y0}, {x1, y1}});
  w->push_back({{x1, y1}, {x0, y1}});
  w->push_back({{x0, y1}, {x0, y0}});
}
inline void addWall(Walls* w, double x0, double y0, double x1, double y1) {
  w->push_back({{x0, y0}, {x1, y1}});
}

inline double castRay(const Walls& walls, const Eigen::Vector2d& o, const Eigen::Vector2d& d,
                      double max_range) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& w : walls) {
    const Eigen::Vector2d e = w.b - w.a;
    const double den = d.x() * e.y() - d.y() * e.x();
    if (std::abs(den) < 1e-12) continue;
    const Eigen::Vector2d ao = w.a - o;
    const double t = (ao.x() * e.y() - ao.y() * e.x()) / den;
    const double s = (ao.x() * d.y() - ao.y() * d.x()) / den;
    if (t > 1e-9 && s >= 0.0 && s <= 1.0 && t < best) best = t;
  }
  return best <= max_range ? best : std::numeric_limits<double>::infinity();
}

struct DriveOptions {
  double step = 0.4;        // metres between nodes
  double turn_step = 0.35;  // rad between nodes when turning on the spot
  int beams = 181;
  double fov = 4.71238898038469;
  double range_max = 30.0;
  double range_sigma = 0.01;
  double odom_trans_sigma = 0.03;  // per metre
  double odom_rot_sigma = 0.03;    // per radian
  double odom_rot_per_metre = 0.01;
};

// Drives through `waypoints` (building frame) in `walls` (building frame); the graph's
// frame is `frame` (its pose in the building frame), so node poses are frame^-1 * true.
inline floor::FloorGraph driveFloor(const Walls& walls,
                                    const std::vector<Eigen::Vector2d>& waypoints,
                                    const geometry::Pose2& frame, int graph_id, double height,
                                    unsigned seed, const DriveOptions& o = {}) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<geometry::Pose2> truth;
  double heading =
      std::atan2(waypoints[1].y() - waypoints[0].y(), waypoints[1].x() - waypoints[0].x());
  geometry::Pose2 pose(waypoints[0].x(), waypoints[0].y(), heading);
  truth.push_back(pose);
  for (std::size_t w = 1; w < waypoints.size(); ++w) {
    const Eigen::Vector2d& target = waypoints[w];
    const Eigen::Vector2d d = target - pose.translation();
    const double want = std::atan2(d.y(), d.x());
    double turn = geometry::angleDiff(want, pose.theta());
    while (std::abs(turn) > 1e-9) {
      const double t = std::clamp(turn, -o.turn_step, o.turn_step);
      pose = geometry::Pose2(pose.x(), pose.y(), pose.theta() + t);
      truth.push_back(pose);
      turn -= t;
    }
    double remaining = d.norm();
    while (remaining > 1e-9) {
      const double s = std::min(o.step, remaining);
      pose = geometry::Pose2(pose.x() + s * std::cos(want), pose.y() + s * std::sin(want), want);
      truth.push_back(pose);
      remaining -= s;
    }
  }
  floor::FloorGraph g;
  g.graph_id = graph_id;
  g.floor_id = graph_id;
  g.floor_height = height;
  geometry::Pose2 odom = truth.front();
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (i > 0) {
      const geometry::Pose2 delta = truth[i - 1].between(truth[i]);
      const double dist = delta.translation().norm();
      const geometry::Pose2 noisy(delta.x() + o.odom_trans_sigma * dist * n01(rng),
                                  delta.y() + o.odom_trans_sigma * dist * n01(rng),
                                  delta.theta() + (o.odom_rot_sigma * std::abs(delta.theta()) +
                                                   o.odom_rot_per_metre * dist) *
                                                      n01(rng));
      odom = odom * noisy;
    }
    floor::FloorNode node;
    node.id = static_cast<int>(i) + 100 * graph_id;
    node.stamp = static_cast<double>(i);
    node.pose = frame.inverse() * truth[i];
    node.odometry = odom;
    node.first_pose = odom;
    sensor::LaserScan& scan = node.scan;
    scan.stamp = node.stamp;
    scan.angle_min = -o.fov / 2;
    scan.angle_increment = o.fov / (o.beams - 1);
    scan.range_min = 0.05;
    scan.range_max = o.range_max;
    for (int b = 0; b < o.beams; ++b) {
      const double a = truth[i].theta() + scan.angle(b);
      const double r =
          castRay(walls, truth[i].translation(), {std::cos(a), std::sin(a)}, o.range_max - 0.01);
      scan.ranges.push_back(std::isfinite(r) ? static_cast<float>(r + o.range_sigma * n01(rng))
                                             : std::numeric_limits<float>::infinity());
    }
    g.nodes.push_back(std::move(node));
  }
  for (std::size_t i = 1; i < g.nodes.size(); ++i)
    g.edges.push_back({g.nodes[i - 1].id, g.nodes[i].id,
                       g.nodes[i - 1].pose.between(g.nodes[i].pose), Eigen::Matrix3d::Identity(),
                       floor::EdgeKind::kOdometry});
  return g;
}

// An office floor 20 x 12 m: corridor, rooms, a shaft; `variant` changes the furniture
// and one room wall, as floors of one building differ.
inline Walls officeFloor(int variant) {
  Walls w;
  addBox(&w, 0, 0, 20, 12);
  addWall(&w, 0, 4, 6, 4);
  addWall(&w, 7.5, 4, 20, 4);
  addWall(&w, 0, 7, 3, 7);
  addWall(&w, 4.5, 7, 12, 7);
  addWall(&w, 13.5, 7, 20, 7);
  addWall(&w, 10, 0, 10, 4);
  addWall(&w, 8, 7, 8, 12);
  addBox(&w, 17, 9, 19, 11);  // shaft
  if (variant == 0) {
    addWall(&w, 15, 7, 15, 12);
    addBox(&w, 3, 9, 4, 10);
    addBox(&w, 12, 1, 14, 2);
  } else {
    addWall(&w, 14, 7, 14, 10);
    addBox(&w, 1, 1, 2, 2.5);
    addBox(&w, 5, 9.5, 6.5, 10.5);
  }
  return w;
}

// Path along the corridor and into a few rooms (building frame).
inline std::vector<Eigen::Vector2d> officePath(int variant) {
  if (variant == 0)
    return {{1, 5.5},    {19, 5.5},  {18, 6},  {12.7, 5.5}, {12.7, 9},
            {12.7, 5.5}, {6.7, 5.5}, {6.7, 2}, {6.7, 5.5},  {1.5, 5.5}};
  return {{19, 5.2},   {3.7, 5.6}, {3.7, 9.5},  {3.7, 5.6},
          {12.8, 5.8}, {12.8, 10}, {12.8, 5.8}, {19, 5.8}};
}

}  // namespace storey::matching::test
