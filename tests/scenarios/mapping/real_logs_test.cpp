// The front end on real laser logs with odometry derived from the corrected poses plus
// seeded noise (5 % of distance per axis, 2°/m + 2 % of the turn in heading), compared
// with the corrected poses by the relation metric (Kümmerle et al. 2009). Only intel runs
// here (about a minute); docs/floor_mapper.md has every log, run with `storey slam`.
#include <gtest/gtest.h>

#include <cstdio>

#include "storey/common/log.h"
#include "storey/io/carmen.h"
#include "storey/mapping/evaluation.h"
#include "storey/mapping/floor_slam.h"
#include "test_support.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;

struct LogData {
  std::vector<sensor::LaserScan> scans;
  std::vector<Pose2> poses;
};

LogData readLog(const std::string& path) {
  io::CarmenReaderOptions options;
  options.strict = false;
  LogData data;
  for (const auto& l : io::readCarmenLasers(path, options)) {
    data.scans.push_back(l.scan);
    data.poses.push_back(l.robotPose());
  }
  // A few stamps in the shared logs repeat or go backwards: order by index.
  for (std::size_t i = 0; i < data.scans.size(); ++i) data.scans[i].stamp = static_cast<double>(i);
  return data;
}

RelationErrors runAndEvaluate(const LogData& log, const std::vector<Pose2>& odometry,
                              const std::vector<Pose2>& reference, const char* name,
                              const FloorSlamOptions& options = {}) {
  common::setLogLevel(common::LogLevel::kError);
  FloorSlam slam(options, "robot", 0, 0, 0.0);
  const OfflineRun run = runOffline(slam, log.scans, odometry);
  std::vector<Pose2> estimate;
  for (const auto& p : run.trajectory) estimate.push_back(odometry.front() * p);
  const RelationErrors e = relationErrors(estimate, reference);
  std::printf("%s: %zu scans in %.1f s; nearby %.4f ± %.4f m, %.3f ± %.3f deg; far %.4f ± %.4f m, %.3f ± %.3f deg; "
              "%zu loop closures\n",
              name, log.scans.size(), run.seconds, e.nearby.translation_mean, e.nearby.translation_std,
              e.nearby.rotation_mean * 180 / M_PI, e.nearby.rotation_std * 180 / M_PI, e.far.translation_mean,
              e.far.translation_std, e.far.rotation_mean * 180 / M_PI, e.far.rotation_std * 180 / M_PI,
              slam.stats().loop_closures);
  EXPECT_EQ(slam.stats().rejected, 0u);
  return e;
}

TEST(RealLogs, IntelWithSimulatedOdometry) {
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  const LogData log = readLog(path);
  ASSERT_GT(log.scans.size(), 900u);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  const RelationErrors e = runAndEvaluate(log, odometry, log.poses, "intel");
  const RelationErrors odo = relationErrors(odometry, log.poses);
  // Achieved (seed 1): nearby 0.0219 m / 0.536°, far 0.265 m / 1.08°. Margins 13-20 %.
  EXPECT_LT(e.nearby.translation_mean, 0.025);
  EXPECT_LT(e.nearby.rotation_mean * 180 / M_PI, 0.65);
  EXPECT_LT(e.far.translation_mean, 0.30);
  EXPECT_LT(e.far.rotation_mean * 180 / M_PI, 1.25);
  // And far better than the odometry it started from.
  EXPECT_LT(e.far.translation_mean, 0.1 * odo.far.translation_mean);
}

TEST(RealLogs, IntelWithTheShippedConfig) {
  // config/floor_mapper.yaml as storey map and the floor_mapper component use it: tracking
  // refined on the local map's points (sub-cell) instead of the likelihood field.
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  const common::ConfigNode config =
      common::ConfigNode::loadFile(test::sourceDir() + "/config/floor_mapper.yaml");
  const FloorSlamOptions options = readFloorSlamOptions(config.child("slam"));
  ASSERT_TRUE(options.matcher.point_refinement);
  const LogData log = readLog(path);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  const RelationErrors e = runAndEvaluate(log, odometry, log.poses, "intel (shipped config)", options);
  // Achieved (seed 1): nearby 0.0188 m / 0.466°, far 0.193 m / 0.83° (session 4, before the
  // normal-noise discount: 0.0189 m / 0.478°, 0.203 m / 0.91°, on which these bounds were
  // set); better than the library defaults' figures above on every count.
  EXPECT_LT(e.nearby.translation_mean, 0.021);
  EXPECT_LT(e.nearby.rotation_mean * 180 / M_PI, 0.53);
  EXPECT_LT(e.far.translation_mean, 0.225);
  EXPECT_LT(e.far.rotation_mean * 180 / M_PI, 1.0);
}

}  // namespace
}  // namespace storey::mapping
