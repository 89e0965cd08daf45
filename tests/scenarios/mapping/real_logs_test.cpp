// The front end on real laser logs with odometry derived from the corrected poses plus
// seeded noise (5 % of distance per axis, 2°/m + 2 % of the turn in heading), compared
// with the corrected poses by the relation metric (Kümmerle et al. 2009). intel, csail,
// infinite-corridor and freiburg-101 run here; docs/floor_mapper.md has every log, run with `storey
// slam`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <ostream>
#include <string>

#include "storey/common/log.h"
#include "storey/io/carmen.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_slam.h"
#include "storey/mapping/input_sequencer.h"
#include "test_support.h"

namespace storey::mapping {
using eval::OdometryNoise;
using eval::OfflineRun;
using eval::ReferencePoseCheck;
using eval::RelationErrors;
using eval::checkReferencePoses;
using eval::relationErrors;
using eval::runOffline;
using eval::simulateOdometry;
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

// Each accepted loop closure's translation error against the reference (node k is the k-th
// scan that became a node).
std::vector<double> closureErrors(const FloorSlam& slam, const OfflineRun& run, const std::vector<Pose2>& reference) {
  std::vector<Pose2> node_reference;
  for (std::size_t i = 0; i < run.status.size(); ++i)
    if (run.status[i] == ScanStatus::kNode) node_reference.push_back(reference[i]);
  std::vector<double> errors;
  for (const auto& a : slam.loopAttempts())
    if (a.outcome == LoopOutcome::kAccepted)
      errors.push_back(node_reference[a.candidate].between(node_reference[a.node]).between(a.measurement)
                           .translation()
                           .norm());
  return errors;
}

// One run of the front end over a log, judged against `reference`.
struct LogRun {
  RelationErrors errors;
  std::vector<Pose2> estimate;         // per scan, in the reference's frame
  std::vector<double> closure_errors;  // per accepted loop closure, m
  FloorSlamStats stats;
};

LogRun runAndEvaluate(const LogData& log, const std::vector<Pose2>& odometry,
                      const std::vector<Pose2>& reference, const char* name,
                      const FloorSlamOptions& options = {}) {
  common::setLogLevel(common::LogLevel::kError);
  FloorSlam slam(options, "robot", 0, 0, 0.0);
  const OfflineRun run = runOffline(slam, log.scans, odometry);
  LogRun out;
  for (const auto& p : run.trajectory) out.estimate.push_back(odometry.front() * p);
  const RelationErrors& e = out.errors = relationErrors(out.estimate, reference);
  std::printf("%s: %zu scans in %.1f s; nearby %.4f ± %.4f m, %.3f ± %.3f deg; far %.4f ± %.4f m, %.3f ± %.3f deg; "
              "%zu loop closures\n",
              name, log.scans.size(), run.seconds, e.nearby.translation_mean, e.nearby.translation_std,
              e.nearby.rotation_mean * 180 / M_PI, e.nearby.rotation_std * 180 / M_PI, e.far.translation_mean,
              e.far.translation_std, e.far.rotation_mean * 180 / M_PI, e.far.rotation_std * 180 / M_PI,
              slam.stats().loop_closures);
  EXPECT_EQ(slam.stats().rejected, 0u);
  out.closure_errors = closureErrors(slam, run, reference);
  out.stats = slam.stats();
  return out;
}

FloorSlamOptions shippedOptions() {
  const common::ConfigNode config =
      common::ConfigNode::loadFile(test::sourceDir() + "/config/floor_mapper.yaml");
  return readFloorSlamOptions(config.child("slam"));
}

TEST(RealLogs, IntelWithSimulatedOdometry) {
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  const LogData log = readLog(path);
  ASSERT_GT(log.scans.size(), 900u);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  const RelationErrors e = runAndEvaluate(log, odometry, log.poses, "intel").errors;
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
  const FloorSlamOptions options = shippedOptions();
  ASSERT_TRUE(options.matcher.point_refinement);
  const LogData log = readLog(path);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  const RelationErrors e =
      runAndEvaluate(log, odometry, log.poses, "intel (shipped config)", options).errors;
  // Bounds: inside the goal (0.03 m / 0.5° nearby, 0.5 m far) and near the figures
  // docs/floor_mapper.md gives for intel as shipped, which must not get worse.
  EXPECT_LT(e.nearby.translation_mean, 0.021);
  EXPECT_LT(e.nearby.rotation_mean * 180 / M_PI, 0.53);
  EXPECT_LT(e.far.translation_mean, 0.225);
  EXPECT_LT(e.far.rotation_mean * 180 / M_PI, 1.0);
}

TEST(RealLogs, CsailAgainstTheReferencePosesItsScansConfirm) {
  // csail's corrected poses are wrong in places: scan 364's reference pose is 20° from
  // where its scan fits its neighbours (score 0.26 there against 0.80), scans 397-399 are
  // 11-12° off as a block, scan 42 11°. Our estimate follows the scans there, and those few
  // relations carried csail's nearby rotation error above 0.5° (docs/floor_mapper.md,
  // "The reference checked against its own scans"). The check finds them from the log
  // alone; against the relations left, the front end meets the 0.03 m / 0.5° goal.
  STOREY_REQUIRE_DATA(path, "carmen/csail-corrected.log.gz");
  const LogData log = readLog(path);
  ASSERT_EQ(log.scans.size(), 406u);
  const std::vector<ReferencePoseCheck> checks = checkReferencePoses(log.scans, log.poses);
  std::vector<bool> contradicted(log.poses.size(), false);
  std::vector<std::size_t> flagged;
  for (const auto& c : checks)
    if (c.contradicted) {
      contradicted[c.index] = true;
      flagged.push_back(c.index);
    }
  EXPECT_EQ(flagged, (std::vector<std::size_t>{42, 364, 397, 399}));
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  const LogRun run =
      runAndEvaluate(log, odometry, log.poses, "csail (shipped config)", shippedOptions());
  const RelationErrors& all = run.errors;
  const RelationErrors checked =
      relationErrors(run.estimate, log.poses, 10.0, 5000, 1, contradicted);
  std::printf("csail against the checked reference: nearby %.4f m / %.3f deg (%zu pairs), far %.3f m / %.2f deg\n",
              checked.nearby.translation_mean, checked.nearby.rotation_mean * 180 / M_PI, checked.nearby.count,
              checked.far.translation_mean, checked.far.rotation_mean * 180 / M_PI);
  EXPECT_EQ(checked.nearby.count, 397u);
  // Achieved (seed 1): all pairs 0.0300 m / 0.626°; checked 0.0290 m / 0.458°, far 0.36 m.
  EXPECT_GT(all.nearby.rotation_mean, checked.nearby.rotation_mean);
  EXPECT_LT(checked.nearby.translation_mean, 0.03);
  EXPECT_LT(checked.nearby.rotation_mean * 180 / M_PI, 0.5);
  EXPECT_LT(checked.far.translation_mean, 0.5);
}

TEST(RealLogs, Freiburg101MeetsTheGoalOnEverySeedTried) {
  // Not among the four logs, but in the shared data: 292 scans of 360 beams in a long
  // hall with offices off it. Its reference has no pose its scans contradict.
  STOREY_REQUIRE_DATA(path, "carmen/freiburg-101-corrected.log.gz");
  const LogData log = readLog(path);
  ASSERT_EQ(log.scans.size(), 292u);
  // The goal (0.03 m / 0.5° nearby) on two seeds; seed 4 has the largest nearby error of
  // seeds 1-6.
  const FloorSlamOptions options = shippedOptions();
  for (const int seed : {1, 4}) {
    const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, seed);
    const std::string label = common::str("freiburg-101 seed ", seed, " (shipped config)");
    const LogRun run = runAndEvaluate(log, odometry, log.poses, label.c_str(), options);
    const RelationErrors odo = relationErrors(odometry, log.poses);
    EXPECT_LT(run.errors.nearby.translation_mean, 0.03) << label;
    EXPECT_LT(run.errors.nearby.rotation_mean * 180 / M_PI, 0.5) << label;
    EXPECT_LT(run.errors.far.translation_mean, 0.2) << label;
    EXPECT_LT(run.errors.far.rotation_mean * 180 / M_PI, 0.7) << label;
    EXPECT_LT(run.errors.far.translation_mean, 0.05 * odo.far.translation_mean) << label;
    ASSERT_FALSE(run.closure_errors.empty()) << label;
    EXPECT_LT(*std::max_element(run.closure_errors.begin(), run.closure_errors.end()), 0.3)
        << label;
  }
}

// csail's .gfs log with the odometry of its ODOM lines, interpolated at each scan's stamp by
// the component's own InputSequencer (as for a bag or live), instead of the pose on each laser
// line (which is the ODOM sample 0.21 s after the scan). At scan 328 that stream holds still
// for 0.42 s while the robot turns 78 degrees, then turns 85 degrees within 0.22 s: one step
// misses a turn beyond the tracking window, the next is a jump. Without the wide search the
// node lands 72 degrees off and a closure later joins it there (far error 8.2 m).
TEST(RealLogs, CsailOdometryStreamThatStallsDoesNotBreakTheMap) {
  STOREY_REQUIRE_DATA(gfs_path, "carmen/csail.corrected.gfs.gz");
  STOREY_REQUIRE_DATA(reference_path, "carmen/csail-corrected.log.gz");
  const LogData reference_log = readLog(reference_path);
  io::CarmenReaderOptions reader_options;
  reader_options.strict = false;
  const io::CarmenLog gfs = io::readCarmenLog(gfs_path, reader_options);
  std::vector<sensor::LaserScan> scans;
  for (const auto& l : gfs.lasers) scans.push_back(l.scan);
  const std::vector<sensor::OdometrySample>& samples = gfs.odometry;
  ASSERT_EQ(scans.size(), 406u);
  EXPECT_GT(samples.size(), 1900u);
  const auto paired = odometryAtScans(scans, samples);
  LogData log;
  std::vector<Pose2> odometry;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    ASSERT_TRUE(paired[i]) << "scan " << i << " has no odometry within max_odometry_gap";
    log.scans.push_back(scans[i]);
    log.poses.push_back(reference_log.poses[i]);
    odometry.push_back(*paired[i]);
  }

  const LogRun run = runAndEvaluate(log, odometry, log.poses, "csail, ODOM stream (shipped config)",
                                    shippedOptions());
  std::printf(
      "found around the last pose: %zu, where the odometry caught up: %zu, odometry disagreed: "
      "%zu\n",
      run.stats.wide_matches, run.stats.caught_up_matches, run.stats.disagreeing_matches);
  // Placed by odometry at the stall, the map broke (far error 8.2 m, a closure 90 degrees off).
  EXPECT_LT(run.errors.far.translation_mean, 0.7);
  EXPECT_LT(run.errors.nearby.translation_mean, 0.045);
  EXPECT_LT(run.errors.nearby.rotation_mean * 180 / M_PI, 1.0);
  ASSERT_FALSE(run.closure_errors.empty());
  EXPECT_LT(*std::max_element(run.closure_errors.begin(), run.closure_errors.end()), 0.5);
}

// infinite-corridor with the shipped config and odometry noise `seed`: the relation errors
// and the worst accepted closure's distance from the reference.
struct CorridorRun {
  RelationErrors errors;
  double worst_closure = 0.0;
  std::size_t closures = 0;
};
CorridorRun runInfiniteCorridor(const std::string& path, int seed) {
  const LogData log = readLog(path);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, seed);
  CorridorRun run;
  const std::string label = common::str("infinite-corridor seed ", seed, " (shipped config)");
  const LogRun evaluated =
      runAndEvaluate(log, odometry, log.poses, label.c_str(), shippedOptions());
  const std::vector<double>& closure_errors = evaluated.closure_errors;
  run.errors = evaluated.errors;
  run.closures = closure_errors.size();
  if (!closure_errors.empty()) run.worst_closure = *std::max_element(closure_errors.begin(), closure_errors.end());
  std::printf("%zu closures, worst %.2f m from the reference\n", run.closures, run.worst_closure);
  return run;
}

TEST(RealLogs, InfiniteCorridorClosesItsLoopsWithoutWrongClosures) {
  // Long corridors that look alike for tens of metres, loops of 200-400 m: after a loop the
  // graph is 10-20 m off, and the first closures must move it that far (in clusters of
  // closures that agree) without letting in one of the look-alike places. Before closures
  // were judged by agreement, seed 1 accepted one 2.8 m off and the long corridor was drawn twice.
  STOREY_REQUIRE_DATA(path, "carmen/infinite-corridor-corrected.log.gz");
  const CorridorRun run = runInfiniteCorridor(path, 1);
  ASSERT_GT(run.closures, 100u);
  // The last pass comes back 20 m off after a 400 m loop; its first right matches tie one old
  // node and must still be taken (held closures are tied where they matched).
  EXPECT_LT(run.worst_closure, 1.0);
  EXPECT_LT(run.errors.nearby.translation_mean, 0.04);
  EXPECT_LT(run.errors.nearby.rotation_mean * 180 / M_PI, 0.5);
  EXPECT_LT(run.errors.far.translation_mean, 4.0);
}

TEST(RealLogs, InfiniteCorridorTrackingRetriesOnTheLastNodes) {
  // The robot moves 1 m per scan, so the 20-node local map spans 20 m of corridor and its
  // far end drifts off the near end by 0.1-0.2 m: scans then find no place scoring 0.35 in
  // it (scan 194 scores 0.65 at its reference pose in a map of the same 20 scans at theirs),
  // and each failure leaves a step to the noisy odometry. The map of the last 5 nodes alone
  // takes them.
  STOREY_REQUIRE_DATA(path, "carmen/infinite-corridor-corrected.log.gz");
  LogData log = readLog(path);
  log.scans.resize(700);
  log.poses.resize(700);
  const auto odometry = simulateOdometry(log.poses, OdometryNoise{}, 1);
  FloorSlamOptions options = shippedOptions();
  options.loop_closure.enabled = false;  // tracking alone
  const LogRun with =
      runAndEvaluate(log, odometry, log.poses, "retry on the last 5 nodes", options);
  options.local_map.retry_nodes = 0;
  const LogRun without = runAndEvaluate(log, odometry, log.poses, "no retry", options);
  const FloorSlamStats &with_retry = with.stats, &without_retry = without.stats;
  std::printf("match failures: %zu without the retry, %zu with it (%zu retries matched)\n",
              without_retry.match_failures, with_retry.match_failures, with_retry.retry_matches);
  // Achieved (seed 1, first 700 scans): 36 failures without, 1 with (7 retries matched);
  // nearby 0.0382 m / 0.557° without, 0.0371 m / 0.443° with. With exact odometry the retry
  // costs a little (0.0195 -> 0.0200 m): a failure there falls back on a perfect step.
  EXPECT_GE(without_retry.match_failures, 10u);
  EXPECT_LE(3 * with_retry.match_failures, without_retry.match_failures);
  EXPECT_GT(with_retry.retry_matches, 0u);
  EXPECT_LT(with.errors.nearby.rotation_mean, without.errors.nearby.rotation_mean);
  EXPECT_LT(with.errors.nearby.translation_mean, 1.02 * without.errors.nearby.translation_mean);
}

// Seeds whose loops once stayed open or took wrong closures: each must close its loops with no
// accepted closure more than 1 m from the reference.
struct CorridorSeed {
  int seed;
  std::size_t min_closures;
  double max_far;     // m, mean far relation error
  const char* story;  // what went wrong there before, and what fixed it
};

void PrintTo(const CorridorSeed& s, std::ostream* os) { *os << "seed " << s.seed; }

class InfiniteCorridorSeed : public ::testing::TestWithParam<CorridorSeed> {};

TEST_P(InfiniteCorridorSeed, ClosesItsLoopsWithoutWrongClosures) {
  STOREY_REQUIRE_DATA(path, "carmen/infinite-corridor-corrected.log.gz");
  const CorridorSeed& p = GetParam();
  std::printf("seed %d: %s\n", p.seed, p.story);
  const CorridorRun run = runInfiniteCorridor(path, p.seed);
  EXPECT_GT(run.closures, p.min_closures);
  EXPECT_LT(run.worst_closure, 1.0);
  EXPECT_LT(run.errors.nearby.rotation_mean * 180 / M_PI, 0.5);
  EXPECT_LT(run.errors.far.translation_mean, p.max_far);
}

// Seeds whose odometry makes one of the corridor's hard cases; each case says what it tests.
INSTANTIATE_TEST_SUITE_P(
    RealLogs, InfiniteCorridorSeed,
    ::testing::Values(
        CorridorSeed{
            17, 100, 4.0,
            "failed matches in the narrow corridor at scans 1566-1575 can leave the heading "
            "0.2-0.3 rad off, and back in the main corridor closures 34 m off can then go in"},
        CorridorSeed{
            2, 100, 4.0,
            "after the 400 m western loop the graph is 14 m off along a look-alike stretch; the "
            "region check must find the cluster's scans fit 14 m away better and move its "
            "closures there"},
        CorridorSeed{
            9, 100, 4.0,
            "the last pass must close: at the window's cap a lone closure needs a unique place, "
            "held closures are tied where they matched, and attempts follow a closure the "
            "region check relocated"},
        CorridorSeed{18, 200, 2.5,
                     "the 300 m loop off the western corridor at (-160, 25) comes back 12-18 m "
                     "off, beyond a "
                     "10 m window: the closure window's cap must reach it"},
        CorridorSeed{
            12, 200, 2.5,
            "windows of 10-20 m hold a look-alike 11 m off along a corridor: a closure alone "
            "there needs a unique place"}),
    [](const ::testing::TestParamInfo<CorridorSeed>& info) {
      return "seed" + std::to_string(info.param.seed);
    });

}  // namespace
}  // namespace storey::mapping
