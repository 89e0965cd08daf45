// A synthetic world mapped by the front end, for the floor_slam tests: the run's estimate
// against the truth, its statistics, closure attempts and edges.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <vector>

#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_slam.h"
#include "synthetic_world.h"

namespace storey::mapping::test {
using eval::OdometryNoise;
using eval::OfflineRun;
using eval::runOffline;
using eval::simulateOdometry;

using geometry::Pose2;

struct WorldRun {
  std::vector<Pose2> truth, odometry, estimate;
  FloorSlamStats stats;
  std::vector<Pose2> node_truth;  // the truth of each node (the k-th scan that became one)
  std::vector<LoopClosureAttempt> attempts;
  std::vector<floor::FloorEdge> edges;
};

// Maps the world's scans (`beams` over 180°) along `truth` with the given odometry.
inline WorldRun runWorld(const test::World& world, const std::vector<Pose2>& truth,
                         const FloorSlamOptions& options, const std::vector<Pose2>& odometry,
                         int beams = 361) {
  WorldRun run;
  run.truth = truth;
  run.odometry = odometry;
  std::vector<sensor::LaserScan> scans;
  for (std::size_t i = 0; i < truth.size(); ++i)
    scans.push_back(world.scan(truth[i], 0.1 * i, beams));
  FloorSlam slam(options, "robot", 0, 0, 0.0);
  const OfflineRun offline = runOffline(slam, scans, run.odometry);
  // The front end starts at the origin; the truth at truth[0].
  for (const auto& p : offline.trajectory) run.estimate.push_back(truth.front() * p);
  run.stats = slam.stats();
  run.attempts = slam.loopAttempts();
  run.edges = slam.floorGraph().edges;
  for (std::size_t i = 0; i < offline.status.size(); ++i)
    if (offline.status[i] == ScanStatus::kNode) run.node_truth.push_back(truth[i]);
  if (std::getenv("STOREY_DEBUG_LOOP")) {
    // Each closure attempt's error against the truth (node k is the k-th scan that became
    // a node), printed as a debugging aid.
    const std::vector<Pose2>& node_truth = run.node_truth;
    for (const auto& a : slam.loopAttempts()) {
      const Pose2 e = node_truth[a.candidate].between(node_truth[a.node]).between(a.measurement);
      std::printf(
          "closure %d -> %d %s%s score %.2f chi2 %.1f sigma %.2f error %.2f %.2f %.2f deg "
          "correction %.2f %.2f %.2f deg\n",
          a.candidate, a.node, loopOutcomeName(a.outcome), a.relocated ? " relocated" : "", a.score,
          a.chi2, a.sigma, e.x(), e.y(), e.theta() * 180 / M_PI, a.correction().x(),
          a.correction().y(), a.correction().theta() * 180 / M_PI);
    }
  }
  return run;
}

// The same with odometry simulated from the truth.
inline WorldRun runWorld(const test::World& world, const std::vector<Pose2>& truth,
                         const FloorSlamOptions& options, std::uint64_t seed,
                         OdometryNoise noise = {}) {
  return runWorld(world, truth, options, simulateOdometry(truth, noise, seed));
}

inline double maxTranslationError(const WorldRun& run) {
  double worst = 0.0;
  for (std::size_t i = 0; i < run.truth.size(); ++i)
    worst = std::max(worst, (run.truth[i].translation() - run.estimate[i].translation()).norm());
  return worst;
}

}  // namespace storey::mapping::test
