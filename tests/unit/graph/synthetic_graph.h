// Small deterministic pose graphs for the graph tests: a robot driving laps around a
// rectangle, with odometry between consecutive poses and loop closures where laps meet.
#pragma once

#include <random>
#include <vector>

#include "storey/graph/pose_graph.h"

namespace storey::graph::testing {

struct Synthetic {
  PoseGraph graph;                     // poses initialised by noisy odometry
  std::vector<geometry::Pose2> truth;  // by node index
};

// `laps` laps of `side` poses per side; measurement noise sigma (m, rad); seeded.
inline Synthetic makeLaps(int laps, int side, double sigma_xy, double sigma_theta, unsigned seed) {
  using geometry::Pose2;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n_xy(0.0, sigma_xy), n_th(0.0, sigma_theta);
  Synthetic s;
  Pose2 pose(0, 0, 0);
  const int per_lap = 4 * side;
  for (int k = 0; k < laps * per_lap; ++k) {
    s.truth.push_back(pose);
    const bool corner = (k % side) == side - 1;
    pose = pose * Pose2(1.0, 0.0, corner ? M_PI / 2 : 0.0);
  }
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  info(0, 0) = info(1, 1) = 1.0 / (sigma_xy * sigma_xy);
  info(2, 2) = 1.0 / (sigma_theta * sigma_theta);
  auto noisy = [&](const Pose2& z) {
    return Pose2(z.x() + n_xy(rng), z.y() + n_xy(rng), z.theta() + n_th(rng));
  };
  const int n = static_cast<int>(s.truth.size());
  for (int k = 0; k < n; ++k) s.graph.addNode(k, Pose2());
  for (int k = 0; k + 1 < n; ++k) {
    s.graph.addEdge(k, k + 1, noisy(s.truth[k].between(s.truth[k + 1])), info, EdgeKind::kOdometry);
  }
  for (int k = per_lap; k < n; ++k) {
    s.graph.addEdge(k - per_lap, k, noisy(s.truth[k - per_lap].between(s.truth[k])), info,
                    EdgeKind::kLoopClosure);
  }
  initializeFromOdometry(s.graph);
  return s;
}

}  // namespace storey::graph::testing
