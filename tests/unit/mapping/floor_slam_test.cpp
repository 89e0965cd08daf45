#include "storey/mapping/floor_slam.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>

#include "bare_options.h"
#include "storey/mapping/evaluation.h"
#include "storey/mapping/floor_sessions.h"
#include "synthetic_world.h"
#include "test_support.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;

using test::pathThrough;

struct WorldRun {
  std::vector<Pose2> truth, odometry, estimate;
  FloorSlamStats stats;
  std::vector<Pose2> node_truth;  // the truth of each node (the k-th scan that became one)
  std::vector<LoopClosureAttempt> attempts;
  std::vector<floor::FloorEdge> edges;
};

// Maps the world's scans (`beams` over 180°) along `truth` with the given odometry.
WorldRun runWorld(const test::World& world, const std::vector<Pose2>& truth,
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
      std::printf("closure %d -> %d %s%s score %.2f chi2 %.1f sigma %.2f error %.2f %.2f %.2f deg "
                  "correction %.2f %.2f %.2f deg\n",
                  a.candidate, a.node, loopOutcomeName(a.outcome), a.relocated ? " relocated" : "", a.score, a.chi2,
                  a.sigma, e.x(), e.y(), e.theta() * 180 / M_PI, a.correction().x(), a.correction().y(), a.correction().theta() * 180 / M_PI);
    }
  }
  return run;
}

// The same with odometry simulated from the truth.
WorldRun runWorld(const test::World& world, const std::vector<Pose2>& truth, const FloorSlamOptions& options,
                  std::uint64_t seed, OdometryNoise noise = {}) {
  return runWorld(world, truth, options, simulateOdometry(truth, noise, seed));
}

double maxTranslationError(const WorldRun& run) {
  double worst = 0.0;
  for (std::size_t i = 0; i < run.truth.size(); ++i)
    worst = std::max(worst, (run.truth[i].translation() - run.estimate[i].translation()).norm());
  return worst;
}

TEST(FloorSlam, TracksThroughAnOfficeWithNoisyOdometry) {
  const test::World world = test::officeWorld();
  const auto truth = pathThrough({{1, 1}, {4.5, 1}, {4.5, 4.5}, {8, 4}, {11, 1}, {11, 4.5}, {6, 7}, {1, 7}, {1, 1}});
  const WorldRun run = runWorld(world, truth, FloorSlamOptions{}, 7);
  const RelationErrors slam = relationErrors(run.estimate, run.truth);
  const RelationErrors odo = relationErrors(run.odometry, run.truth);
  EXPECT_LT(slam.nearby.translation_mean, 0.02);
  EXPECT_LT(slam.nearby.rotation_mean, 0.3 * M_PI / 180);
  EXPECT_LT(maxTranslationError(run), 0.12);
  EXPECT_LT(slam.nearby.translation_mean, odo.nearby.translation_mean);
  EXPECT_GT(run.stats.matched, run.stats.nodes * 9 / 10);
}

TEST(FloorSlam, ASuccessorMatchIsNotPulledOntoWhatTheSuccessorsSaw) {
  // A forward-looking laser 1 m per scan along a corridor with niches: node k's scan sees
  // the walls between it and node k+1, which none of the nodes after it saw. Matched against
  // their map with those points, it slid forward onto the walls they did see (the step came
  // out short: 0.1 m on infinite-corridor). Only points where their map has looked count.
  test::World world;
  for (int x = -4; x < 80; x += 4) {  // 2 m wide; on each side a niche 0.8 m wide every 4 m
    for (const double side : {1.0, -1.0}) {
      const double niche = x + (side > 0 ? 1.0 : 3.0);
      world.addWall(x, side, niche, side);
      world.addWall(niche, side, niche, 1.4 * side);
      world.addWall(niche, 1.4 * side, niche + 0.8, 1.4 * side);
      world.addWall(niche + 0.8, 1.4 * side, niche + 0.8, side);
      world.addWall(niche + 0.8, side, x + 4, side);
    }
  }
  const auto truth = pathThrough({{0, 0}, {60, 0}}, 1.0);
  FloorSlamOptions options;
  options.successor_match_nodes = 5;
  // Exact odometry: what is left is the matches' own error.
  const WorldRun run = runWorld(world, truth, options, truth, /*beams=*/181);
  const std::vector<Pose2>& node_truth = run.node_truth;
  double along_sum = 0.0, tracking_sum = 0.0;
  std::size_t back_edges = 0, tracking_edges = 0;
  for (const auto& e : run.edges) {
    if (e.kind != floor::EdgeKind::kScanMatch) continue;
    const double error = e.measurement.x() - node_truth[e.from].between(node_truth[e.to]).x();
    if (e.to == e.from - 1) {  // positive: the measured step is shorter than the true one
      ++back_edges;
      along_sum += error;
    } else if (e.to == e.from + 1) {
      ++tracking_edges;
      tracking_sum -= error;
    }
  }
  ASSERT_GT(back_edges, 40u);
  std::printf("%zu successor edges: %+.4f m short on average (%zu tracking edges: %+.4f m)\n",
              back_edges, along_sum / back_edges, tracking_edges, tracking_sum / tracking_edges);
  // Achieved: 0.022 m short (tracking edges: 0.016 m short, their scans' last metre ahead
  // being beyond what the scans before them saw); with every point, 0.117 m.
  EXPECT_LT(std::abs(along_sum / back_edges), 0.04);
}

// The successor edges (from node k+1 back to k): their count, and each one's error against
// the true step weighed by the information it claims (3 on average for a covariance that
// is right; these are halved by successor_match_weight): the mean and the worst.
struct SuccessorEdgeNees {
  std::size_t count = 0;
  double mean = 0.0, worst = 0.0;
};
SuccessorEdgeNees successorEdgeNees(const std::vector<floor::FloorEdge>& edges,
                                    const std::vector<Pose2>& node_truth) {
  SuccessorEdgeNees r;
  double sum = 0.0;
  for (const auto& e : edges) {
    if (e.kind != floor::EdgeKind::kScanMatch || e.to != e.from - 1) continue;
    ++r.count;
    const Pose2 error = node_truth[e.from].between(node_truth[e.to]).between(e.measurement);
    const Eigen::Vector3d v(error.x(), error.y(), error.theta());
    sum += v.dot(e.information * v);
    r.worst = std::max(r.worst, v.dot(e.information * v));
  }
  if (r.count > 0) r.mean = sum / r.count;
  return r;
}

TEST(FloorSlam, SuccessorMatchesAtFinishLeaveTheLoopClosuresToTheTrackingGraph) {
  // The nodes are matched against their successors only when the graph is finished: until
  // then the graph is the tracking graph of a run without them (the same closures, the same
  // poses), and finish() adds one edge per node that has 5 successors, each within the
  // covariance it claims, and lowers the nearby rotation error.
  const test::World world = test::officeWorld();
  const auto truth = pathThrough(
      {{1, 1}, {4.5, 1}, {4.5, 4.5}, {8, 4}, {11, 1}, {11, 4.5}, {6, 7}, {1, 7}, {1, 1}});
  const auto odometry = simulateOdometry(truth, OdometryNoise{}, 7);
  FloorSlamOptions at_finish, none;
  ASSERT_EQ(at_finish.successor_match_nodes, 5);
  none.successor_match_nodes = 0;
  FloorSlam with(at_finish, "robot", 0, 0, 0.0), without(none, "robot", 0, 0, 0.0);
  std::vector<sensor::LaserScan> scans;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    scans.push_back(world.scan(truth[i], 0.1 * i));
    with.addScan(scans.back(), odometry[i]);
    without.addScan(scans.back(), odometry[i]);
  }
  EXPECT_EQ(with.stats().successor_matches, 0u);
  ASSERT_EQ(with.floorGraph().edges.size(), without.floorGraph().edges.size());
  ASSERT_EQ(with.stats().loop_closures, without.stats().loop_closures);
  ASSERT_GT(with.stats().loop_closures, 0u);
  for (std::size_t i = 0; i < with.floorGraph().nodes.size(); ++i)
    ASSERT_LT(with.floorGraph()
                  .nodes[i]
                  .pose.between(without.floorGraph().nodes[i].pose)
                  .translation()
                  .norm(),
              1e-9);

  with.finish();
  without.finish();
  const std::size_t nodes = with.floorGraph().nodes.size();
  EXPECT_GT(with.stats().successor_matches, (nodes - 6) * 9 / 10);
  EXPECT_LE(with.stats().successor_matches, nodes - 5);  // the last 5 nodes have no 5 successors
  EXPECT_EQ(with.floorGraph().edges.size(),
            without.floorGraph().edges.size() + with.stats().successor_matches);
  // A second finish (the robot left the floor again without new nodes) adds nothing.
  with.finish();
  EXPECT_EQ(with.floorGraph().edges.size(),
            without.floorGraph().edges.size() + with.stats().successor_matches);

  std::vector<Pose2> node_truth;
  for (const auto& node : with.floorGraph().nodes) {
    const auto at = std::find_if(scans.begin(), scans.end(),
                                 [&](const sensor::LaserScan& s) { return s.stamp == node.stamp; });
    node_truth.push_back(truth[at - scans.begin()]);
  }
  const SuccessorEdgeNees nees = successorEdgeNees(with.floorGraph().edges, node_truth);
  ASSERT_EQ(nees.count, with.stats().successor_matches);
  EXPECT_LT(nees.mean, 3.0);
  EXPECT_LT(nees.worst, 20.0);
  auto nodePoses = [](const FloorSlam& slam) {
    std::vector<Pose2> poses;
    for (const auto& node : slam.floorGraph().nodes) poses.push_back(node.pose);
    return poses;
  };
  const RelationErrors smoothed = relationErrors(nodePoses(with), node_truth);
  const RelationErrors tracked = relationErrors(nodePoses(without), node_truth);
  std::printf(
      "%zu successor edges at finish, mean NEES %.2f; nearby rotation %.3f deg, without %.3f deg\n",
      nees.count, nees.mean, smoothed.nearby.rotation_mean * 180 / M_PI,
      tracked.nearby.rotation_mean * 180 / M_PI);
  EXPECT_LT(smoothed.nearby.rotation_mean, tracked.nearby.rotation_mean);
}

TEST(FloorSlam, AlongABareCorridorOdometryDecides) {
  // Two parallel walls and nothing else in range: scans say nothing about the position
  // along the corridor. The match's result there lags at the local map's frontier; the
  // search's prior holds it near the odometry's prediction, and with the degenerate
  // direction taken from odometry the track moves as the robot does. (Poses as tracked,
  // before any optimisation.)
  const test::World world = test::corridorWorld();
  const auto truth = pathThrough({{-30, 0}, {10, 0}});
  const auto odometry = simulateOdometry(truth, OdometryNoise{}, 3);
  auto track = [&](double degenerate_ratio) {
    FloorSlamOptions options;
    options.degenerate_ratio = degenerate_ratio;
    options.loop_closure.enabled = false;
    FloorSlam slam(options, "robot", 0, 0, 0.0);
    std::vector<Pose2> poses;
    for (std::size_t i = 0; i < truth.size(); ++i)
      poses.push_back(truth.front() * slam.addScan(world.scan(truth[i], 0.1 * i), odometry[i]).pose);
    return poses;
  };
  const std::vector<Pose2> followed = track(0.1), unfused = track(0.0);
  const double travelled = truth.back().x() - truth.front().x();
  const double odometry_travelled = odometry.front().between(odometry.back()).x();
  // Where odometry puts it, within odometry's own error: 5 % per 0.25 m step is a random
  // walk of about 0.16 m over these 40 m (seed 3: odometry 0.23 m short, the track 0.05 m
  // long; the match's weak information along the axis still counts a little).
  EXPECT_NEAR(followed.back().x() - truth.front().x(), travelled, 0.5);
  EXPECT_NEAR(followed.back().x() - truth.front().x(), odometry_travelled, 0.5);
  // Across the corridor and in heading the walls still decide.
  double worst_y = 0.0, worst_heading = 0.0;
  for (const Pose2& p : followed) {
    worst_y = std::max(worst_y, std::abs(p.y()));
    worst_heading = std::max(worst_heading, std::abs(p.theta()));
  }
  std::printf(
      "along %.3f (odometry %.3f, truth %.3f), without the fusion %.3f; worst y %.3f m, heading "
      "%.3f deg\n",
      followed.back().x() - truth.front().x(), odometry_travelled, travelled,
      unfused.back().x() - truth.front().x(), worst_y, worst_heading * 180 / M_PI);
  EXPECT_LT(worst_y, 0.1);
  EXPECT_LT(worst_heading, 0.01);
  // Without the fusion the lag adds up (seed 3: 1.6 m short over 40 m).
  EXPECT_GT(std::abs(unfused.back().x() - truth.back().x()),
            2 * std::abs(followed.back().x() - truth.back().x()));
}

TEST(FloorSlam, NodesOnlyWhenMovedEnough) {
  const test::World world = test::officeWorld();
  FloorSlamOptions options;
  options.node.min_translation = 0.5;
  FloorSlam slam(options, "robot", 0, 0, 0.0);
  for (int i = 0; i < 20; ++i) {
    const Pose2 pose(2 + 0.1 * i, 1.2, 0.0);
    slam.addScan(world.scan(pose, i), pose);
  }
  // 1.9 m in 0.1 m steps with a node every 0.5 m: the first and three more.
  EXPECT_EQ(slam.floorGraph().nodes.size(), 4u);
  EXPECT_EQ(slam.stats().skipped, 16u);
  for (const auto& node : slam.floorGraph().nodes) {
    EXPECT_FALSE(node.scan.ranges.empty());
    EXPECT_TRUE(node.odometry.isFinite());
  }
  bool has_odometry = false, has_match = false;
  for (const auto& e : slam.floorGraph().edges) {
    has_odometry |= e.kind == floor::EdgeKind::kOdometry;
    has_match |= e.kind == floor::EdgeKind::kScanMatch;
  }
  EXPECT_TRUE(has_odometry);
  EXPECT_TRUE(has_match);
}

// The start every test with one odd scan drives: six scans with exact odometry, 0.3 m and
// 0.05 rad apart, from (2, 1.2, 0) along the office's corridor.
void driveOfficeStart(FloorSlam& slam, const test::World& world) {
  for (int i = 0; i < 6; ++i) {
    const Pose2 p(2 + 0.3 * i, 1.2, 0.05 * i);
    slam.addScan(world.scan(p, i), p);
  }
}

// A front end with `options` that has driven that start.
std::unique_ptr<FloorSlam> officeSlamAfterStart(const FloorSlamOptions& options,
                                                const test::World& world) {
  auto slam = std::make_unique<FloorSlam>(options, "robot", 0, 0, 0.0);
  driveOfficeStart(*slam, world);
  return slam;
}

class FloorSlamBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    driveOfficeStart(slam_, world_);
    nodes_before_ = slam_.floorGraph().nodes.size();
    edges_before_ = slam_.floorGraph().edges.size();
  }
  ScanResult feed(const Pose2& pose, double stamp, const Pose2* odometry = nullptr) {
    return slam_.addScan(world_.scan(pose, stamp), odometry ? *odometry : pose);
  }
  void expectUnchanged() {
    EXPECT_EQ(slam_.floorGraph().nodes.size(), nodes_before_);
    EXPECT_EQ(slam_.floorGraph().edges.size(), edges_before_);
  }
  test::World world_ = test::officeWorld();
  FloorSlam slam_{FloorSlamOptions{}, "robot", 0, 0, 0.0};
  std::size_t nodes_before_ = 0, edges_before_ = 0;
};

TEST_F(FloorSlamBadInput, NoReturnInRangeIsPlacedByOdometry) {
  sensor::LaserScan scan = world_.scan(Pose2(4, 1.2, 0), 10.0);
  for (auto& r : scan.ranges) r = std::numeric_limits<float>::quiet_NaN();
  const ScanResult r = slam_.addScan(scan, Pose2(4, 1.2, 0));
  EXPECT_EQ(r.status, ScanStatus::kSkipped);
  EXPECT_NE(r.reason.find("no returns in range"), std::string::npos);
  EXPECT_EQ(slam_.stats().rejected, 0u);
  EXPECT_LT(
      (r.pose.translation() - Pose2(2, 1.2, 0).between(Pose2(4, 1.2, 0)).translation()).norm(),
      0.01);
  expectUnchanged();
  // And mapping goes on.
  EXPECT_EQ(feed(Pose2(4, 1.2, 0.3), 11.0).status, ScanStatus::kNode);
}

TEST_F(FloorSlamBadInput, TimeGoingBackwards) {
  const ScanResult r = feed(Pose2(4, 1.2, 0), 2.5);
  EXPECT_EQ(r.status, ScanStatus::kRejected);
  EXPECT_NE(r.reason.find("backwards"), std::string::npos);
  expectUnchanged();
}

TEST_F(FloorSlamBadInput, NonFiniteOdometryAndBrokenScan) {
  const Pose2 nan_pose(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  EXPECT_EQ(feed(Pose2(4, 1.2, 0), 10.0, &nan_pose).status, ScanStatus::kRejected);
  sensor::LaserScan scan = world_.scan(Pose2(4, 1.2, 0), 10.0);
  scan.angle_increment = 0.0;
  EXPECT_EQ(slam_.addScan(scan, Pose2(4, 1.2, 0)).status, ScanStatus::kRejected);
  scan.ranges.clear();
  EXPECT_EQ(slam_.addScan(scan, Pose2(4, 1.2, 0)).status, ScanStatus::kRejected);
  expectUnchanged();
}

TEST_F(FloorSlamBadInput, OdometryJumpIsNotTrusted) {
  // The robot moves 0.3 m but odometry says 5 m: the scan must still land where it is.
  const Pose2 truth(3.8, 1.2, 0.3);
  const Pose2 jumped(8.8, 1.2, 0.3);
  const ScanResult r = feed(truth, 10.0, &jumped);
  ASSERT_EQ(r.status, ScanStatus::kNode) << r.reason;
  EXPECT_TRUE(r.wide);
  EXPECT_FALSE(r.odometry_agrees);
  EXPECT_EQ(slam_.stats().wide_matches, 1u);
  EXPECT_LT((r.pose.translation() - (Pose2(2, 1.2, 0).between(truth)).translation()).norm(), 0.05);
  // No odometry edge across the jump.
  EXPECT_NE(slam_.floorGraph().edges.back().kind, floor::EdgeKind::kOdometry);
  for (const auto& e : slam_.floorGraph().edges)
    EXPECT_FALSE(e.kind == floor::EdgeKind::kOdometry && e.to == r.node_id);
  // Later odometry steps are trusted again, relative to the new odometry frame.
  const Pose2 truth2(4.2, 1.2, 0.3), odo2 = jumped * truth.between(truth2);
  const ScanResult r2 = feed(truth2, 11.0, &odo2);
  ASSERT_EQ(r2.status, ScanStatus::kNode);
  EXPECT_TRUE(r2.odometry_agrees);
  EXPECT_LT((r2.pose.translation() - (Pose2(2, 1.2, 0).between(truth2)).translation()).norm(), 0.05);
}

// Odometry whose heading is stale for one scan (csail's ODOM stream holds still for 0.4 s,
// then turns 85 degrees at once): the robot turned 0.7 rad, twice the tracking window, before
// odometry says so. The scan is found around the last pose; the next scan is found whether
// the odometry catches up (stale: where its motion since it last agreed puts it) or never
// does (a wheel slipped), and no odometry step across the stale one becomes an edge.
TEST(FloorSlam, AScanOdometryTurnedTooLittleIsFoundAroundTheLastPose) {
  const test::World world = test::officeWorld();
  const Pose2 stale_truth(3.8, 1.2, 0.95), stale_odometry(3.8, 1.2, 0.25);
  const Pose2 next_truth(4.0, 1.3, 1.0);
  const Pose2 start(2, 1.2, 0);
  auto heading_error = [&](const ScanResult& r, const Pose2& truth) {
    return std::abs(geometry::angleDiff(r.pose.theta(), start.between(truth).theta()));
  };
  for (const bool catches_up : {true, false}) {
    SCOPED_TRACE(catches_up ? "odometry catches up" : "odometry slipped");
    const auto slam = officeSlamAfterStart(FloorSlamOptions{}, world);
    const ScanResult stale = slam->addScan(world.scan(stale_truth, 10.0), stale_odometry);
    // Caught up: odometry is the truth again. Slipped: it moves on from where it stalled.
    const Pose2 next_odometry =
        catches_up ? next_truth : stale_odometry * stale_truth.between(next_truth);
    const ScanResult next = slam->addScan(world.scan(next_truth, 11.0), next_odometry);
    ASSERT_EQ(stale.status, ScanStatus::kNode) << stale.reason;
    ASSERT_EQ(next.status, ScanStatus::kNode) << next.reason;
    EXPECT_TRUE(stale.wide);
    EXPECT_TRUE(next.matched);
    EXPECT_EQ(next.caught_up, catches_up);
    EXPECT_LT(heading_error(stale, stale_truth), 0.02);
    EXPECT_LT(heading_error(next, next_truth), 0.02);
    EXPECT_LT((next.pose.translation() - start.between(next_truth).translation()).norm(), 0.05);
    bool odometry_edge_into_stale = false, odometry_edge_into_next = false;
    for (const auto& e : slam->floorGraph().edges) {
      if (e.kind != floor::EdgeKind::kOdometry) continue;
      odometry_edge_into_stale |= e.to == stale.node_id;
      odometry_edge_into_next |= e.to == next.node_id;
    }
    // The step that missed the turn is no edge; nor is the one after it, which starts at a
    // node where the odometry disagreed.
    EXPECT_FALSE(odometry_edge_into_stale);
    EXPECT_FALSE(odometry_edge_into_next);
  }
}

// Odometry that stalls while the robot turns in place, then catches up by 1.8 rad in one
// step. Every scan is tracked: those in the stall are found beyond the odometry's window
// (around the last pose), and the one after the catch-up where the odometry's motion since
// it last agreed with the scans puts it, not 1.8 rad beyond the last scan.
TEST(FloorSlam, OdometryThatStallsInATurnIsTrackedAndItsCatchUpFound) {
  const test::World world = test::officeWorld();
  const auto slam = officeSlamAfterStart(FloorSlamOptions{}, world);
  const Pose2 start(2, 1.2, 0);
  const Pose2 last(3.5, 1.2, 0.25);
  for (int k = 1; k <= 3; ++k) {  // turning, odometry stalled at the last pose
    const Pose2 truth(3.5, 1.2, 0.25 + 0.5 * k);
    const ScanResult r = slam->addScan(world.scan(truth, 6 + k), last);
    ASSERT_NE(r.status, ScanStatus::kRejected) << r.reason;
    EXPECT_TRUE(r.matched) << k;
    EXPECT_FALSE(r.odometry_agrees) << k;
    EXPECT_LT(std::abs(geometry::angleDiff(r.pose.theta(), start.between(truth).theta())), 0.02)
        << k;
  }
  const Pose2 turned(3.5, 1.2, 0.25 + 1.8);
  const ScanResult r = slam->addScan(world.scan(turned, 10.0), turned);
  ASSERT_EQ(r.status, ScanStatus::kNode) << r.reason;
  EXPECT_TRUE(r.matched);
  EXPECT_TRUE(r.caught_up);
  EXPECT_TRUE(r.odometry_agrees);
  EXPECT_LT(std::abs(geometry::angleDiff(r.pose.theta(), start.between(turned).theta())), 0.02);
  EXPECT_LT((r.pose.translation() - start.between(turned).translation()).norm(), 0.05);
}

TEST_F(FloorSlamBadInput, DifferentBeamCountIsMatched) {
  const Pose2 truth(3.8, 1.2, 0.3);
  const ScanResult r = slam_.addScan(world_.scan(truth, 10.0, 181), truth);
  ASSERT_EQ(r.status, ScanStatus::kNode) << r.reason;
  EXPECT_TRUE(r.matched);
  EXPECT_EQ(slam_.floorGraph().nodes.back().scan.size(), 181u);
  EXPECT_LT((r.pose.translation() - (Pose2(2, 1.2, 0).between(truth)).translation()).norm(), 0.03);
}

// A scan 0.2 m to the side of where the odometry step puts the robot (13 sigma of the
// odometry model for a 0.3 m step): the prior is flat beyond its 99 % region, so the scan
// goes where it fits clearly better, and the odometry that disagrees is no edge.
TEST(FloorSlam, AScanFarFromThePredictionGoesWhereItFitsClearlyBetter) {
  const test::World world = test::officeWorld();
  const auto slam = officeSlamAfterStart(FloorSlamOptions{}, world);
  const Pose2 claimed(3.8, 1.2, 0.3), truth(3.8, 1.4, 0.3);
  const ScanResult r = slam->addScan(world.scan(truth, 10.0), claimed);
  ASSERT_EQ(r.status, ScanStatus::kNode) << r.reason;
  EXPECT_TRUE(r.matched);
  EXPECT_FALSE(r.odometry_agrees);
  const Pose2 start(2, 1.2, 0);
  EXPECT_LT((r.pose.translation() - start.between(truth).translation()).norm(), 0.03);
  EXPECT_EQ(slam->floorGraph().edges.back().kind, floor::EdgeKind::kScanMatch);
}

TEST(FloorSlam, LoopClosureCorrectsDrift) {
  const test::World world = test::ringCorridorWorld();
  const auto truth = pathThrough({{1, 1}, {23, 1}, {23, 15}, {1, 15}, {1, 1}, {12, 1}});
  OdometryNoise noise;
  noise.rotation_per_meter = 3.0 * M_PI / 180;
  FloorSlamOptions with = test::bareOptions();
  FloorSlamOptions rebuilding = with;  // a fresh candidate map for every attempt
  rebuilding.loop_closure.submap_reuse_nodes = 0;
  FloorSlamOptions without = test::bareOptions();
  without.loop_closure.enabled = false;
  const WorldRun closed = runWorld(world, truth, with, 11, noise);
  const WorldRun closed_rebuilding = runWorld(world, truth, rebuilding, 11, noise);
  const WorldRun open = runWorld(world, truth, without, 11, noise);
  EXPECT_GE(closed.stats.loop_closures, 1u);
  EXPECT_GE(closed_rebuilding.stats.loop_closures, 1u);
  // Reusing the last candidate map for nearby candidates builds fewer maps than reusing it
  // for the same candidate only (every accepted closure moves the nodes and forces a new one).
  EXPECT_EQ(closed.stats.loop_attempts, closed_rebuilding.stats.loop_attempts);
  EXPECT_LT(closed.stats.loop_maps_built, closed_rebuilding.stats.loop_maps_built);
  EXPECT_LT(closed_rebuilding.stats.loop_maps_built, closed_rebuilding.stats.loop_attempts);
  if (std::getenv("STOREY_DEBUG_LOOP")) {
    for (std::size_t i = 0; i < closed.truth.size(); i += 5)
      std::printf("%zu truth %.2f %.2f est %.2f %.2f open %.2f %.2f\n", i, closed.truth[i].x(), closed.truth[i].y(),
                  closed.estimate[i].x(), closed.estimate[i].y(), open.estimate[i].x(), open.estimate[i].y());
  }
  // Back at the start, the closed loop knows where it is relative to its first pass (the
  // pose at the same place on the first leg); the open one has drifted.
  std::size_t first_pass = 0;
  for (std::size_t i = 0; i < truth.size() / 2; ++i)
    if ((truth[i].translation() - truth.back().translation()).norm() <
        (truth[first_pass].translation() - truth.back().translation()).norm())
      first_pass = i;
  auto loopError = [&](const WorldRun& r) {
    const Pose2 e = r.truth[first_pass].between(r.truth.back()).between(
        r.estimate[first_pass].between(r.estimate.back()));
    return e.translation().norm();
  };
  EXPECT_LT(loopError(closed), 0.1);
  EXPECT_LT(loopError(closed_rebuilding), 0.1);
  EXPECT_GT(loopError(open), 0.3);
  // Known weakness (docs/floor_mapper.md): in this long, nearly featureless ring only
  // odometry constrains the corridors' axes, and the optimiser spreads the closure's
  // correction over them, so the absolute error does not drop as much as the loop error.
}

TEST(FloorSlam, ALargeDriftIsClosedByClosuresThatAgree) {
  // A ring whose first leg is a bare corridor where the wheels slip: odometry says 8 % more
  // than was driven, and the scans cannot tell (only the walls along it are in range). Back
  // at the start the graph is metres off; no single closure may move it that far, a
  // cluster of closures that agree does.
  test::World world;
  world.addBox(0, 0, 40, 14);
  world.addBox(2, 2, 38, 12);
  for (double x = 1; x < 40; x += 7.3) world.addBox(x, 13.6, x + 0.4, 13.95);  // doors on the far leg
  world.addBox(38.1, 5, 38.5, 5.6);
  world.addBox(1.6, 7, 1.95, 7.5);
  world.addBox(0.05, 3, 0.4, 3.4);
  world.addWall(0.5, 0, 0.5, 0.4);
  const auto truth = pathThrough({{1, 1}, {39, 1}, {39, 13}, {1, 13}, {1, 1}, {10, 1}});
  // Slip on the first leg: every step there 8 % longer than driven, built step by step so
  // that each slipped step carries on from the last.
  const std::vector<Pose2> simulated = simulateOdometry(truth, OdometryNoise{}, 5);
  std::vector<Pose2> odometry = {simulated.front()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Pose2 step = simulated[i - 1].between(simulated[i]);
    if (truth[i].y() < 1.5 && truth[i].x() < 38.9 && i < truth.size() / 2)
      step = Pose2(step.x() * 1.08, step.y(), step.theta());
    odometry.push_back(odometry.back() * step);
  }
  auto run = [&](int cluster_size) {
    FloorSlamOptions options = test::bareOptions();
    options.loop_closure.cluster_size = cluster_size;
    return runWorld(world, truth, options, odometry);
  };
  const WorldRun clustered = run(3), alone = run(1);
  std::printf("clusters %zu closures %zu of %zu, max error %.2f m; closures alone: %zu of %zu, max error %.2f m\n",
              clustered.stats.loop_clusters, clustered.stats.loop_closures, clustered.stats.loop_attempts,
              maxTranslationError(clustered), alone.stats.loop_closures, alone.stats.loop_attempts,
              maxTranslationError(alone));
  // Where the robot is, relative to the start, when it is back at the start corner (the loop
  // the closures close), and where it ended, 9 m along the first leg again.
  auto errorAt = [](const WorldRun& r, std::size_t k) {
    return (r.truth.front().between(r.truth[k]).translation() -
            r.estimate.front().between(r.estimate[k]).translation()).norm();
  };
  std::size_t back = truth.size() / 2;
  while (back < truth.size() && (truth[back].translation() - truth.front().translation()).norm() > 0.2) ++back;
  ASSERT_LT(back, truth.size());
  const std::size_t end = truth.size() - 1;
  std::printf("back at the start: error %.2f m, alone %.2f m; at the end %.2f m, alone %.2f m\n",
              errorAt(clustered, back), errorAt(alone, back), errorAt(clustered, end), errorAt(alone, end));
  // Achieved: back at the start 0.78 m with clusters (6 clusters, 12 closures), 2.41 m with
  // closures alone (6 of 23). At the end, 9 m into the bare first leg, 0.75 m and 1.58 m:
  // nothing in that corridor tells its length, so the graph keeps the leg's 8 % stretch
  // there (0.72 m over 9 m). With 3 m of slip the optimiser spreads the correction by
  // bending the legs (largest error 2.60 m), the weakness LoopClosureCorrectsDrift notes.
  EXPECT_GE(clustered.stats.loop_clusters, 1u);
  EXPECT_LT(errorAt(clustered, back), 1.0);
  EXPECT_GT(errorAt(alone, back), 1.5);
}

// A 60 m x 14 m ring corridor, 2 m wide, whose bottom leg has pillars every `period` on both
// walls from x = first_pillar on; a few features elsewhere so the other legs can be tracked.
const double kRingLength = 60.0;
test::World ringWithPillars(double period, double first_pillar) {
  test::World world;
  world.addBox(0, 0, kRingLength, 14);
  world.addBox(2, 2, kRingLength - 2, 12);
  for (double x = first_pillar; x < kRingLength - 3; x += period) {
    world.addBox(x, 0.05, x + 0.4, 0.4);
    world.addBox(x + 1, 1.6, x + 1.4, 1.95);
  }
  world.addBox(kRingLength - 1.9, 5, kRingLength - 1.5, 5.6);
  world.addBox(1.6, 7, 1.95, 7.5);
  world.addBox(0.05, 9, 0.4, 9.4);
  return world;
}

// Once round the ring and back along the bottom leg to x = 28.
std::vector<Pose2> ringPath() {
  return pathThrough({{1, 1}, {kRingLength - 1, 1}, {kRingLength - 1, 13}, {1, 13}, {1, 1}, {28, 1}});
}

// Simulated odometry (seed 5) whose steps on the bare top leg are scaled by `slip`, built
// step by step.
std::vector<Pose2> slipOnTopLeg(const std::vector<Pose2>& truth, double slip) {
  const std::vector<Pose2> simulated = simulateOdometry(truth, OdometryNoise{}, 5);
  std::vector<Pose2> odometry = {simulated.front()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Pose2 step = simulated[i - 1].between(simulated[i]);
    if (truth[i].y() > 12.5 && truth[i].x() > 1.1 && truth[i].x() < kRingLength - 1.1)
      step = Pose2(step.x() * slip, step.y(), step.theta());
    odometry.push_back(odometry.back() * step);
  }
  return odometry;
}

// A closure's error against the truth (m).
double closureError(const WorldRun& r, const LoopClosureAttempt& a) {
  return r.node_truth[a.candidate].between(r.node_truth[a.node]).between(a.measurement).translation().norm();
}

// Where the robot ended along the bottom leg relative to its start, error (m).
double endAlongError(const WorldRun& r) {
  return r.estimate.front().between(r.estimate.back()).x() - r.truth.front().between(r.truth.back()).x();
}

TEST(FloorSlam, ARegionCheckKeepsClosuresOffALookAlikeStretch) {
  // A 60 m x 14 m ring whose bottom leg has pillars every 7 m on both walls, and one wide
  // niche-like block that breaks the pattern. The top leg is bare and the wheels slip there:
  // odometry says 15 % more than was driven. Back on the bottom leg the graph is about one
  // period (7 m) behind along the corridor, beyond the closures' match window (4 m), so
  // every closure finds the pillars one period off, and those closures agree with each
  // other. The region check searches the last scans, joined, over the whole region the
  // graph's uncertainty allows (here about 15 m): the true place fits better (the block).
  const double period = 7.0;
  test::World world = ringWithPillars(period, 3.0);
  world.addBox(12, 0.05, 13.5, 0.6);  // the irregularity
  const auto truth = ringPath();
  const std::vector<Pose2> odometry = slipOnTopLeg(truth, 1.15);
  auto run = [&](double verify_window) {
    FloorSlamOptions options =
        test::bareOptions();  // max_linear_window 4 m, cluster_verify_distance 4 m
    options.loop_closure.cluster_verify_window = verify_window;
    return runWorld(world, truth, options, odometry);
  };
  struct Figures {
    int accepted = 0, relocated = 0;
    double worst = 0.0;  // largest error of an accepted closure against the truth (m)
    double along = 0.0;  // where the robot ended along the bottom leg relative to its start, error (m)
  };
  auto figures = [](const WorldRun& r) {
    Figures f;
    for (const auto& a : r.attempts) {
      if (a.outcome != LoopOutcome::kAccepted) continue;
      ++f.accepted;
      f.relocated += a.relocated ? 1 : 0;
      f.worst = std::max(f.worst, closureError(r, a));
    }
    f.along = endAlongError(r);
    return f;
  };
  const WorldRun off = run(0.0), on = run(30.0);
  const Figures f_off = figures(off), f_on = figures(on);
  auto print = [](const char* name, const WorldRun& r, const Figures& f) {
    std::printf("%s: clusters %zu (refused %zu), closures %d of %zu (relocated %d), worst closure %.2f m, "
                "end along %.2f m, max error %.2f m\n",
                name, r.stats.loop_clusters, r.stats.loop_clusters_ambiguous, f.accepted, r.stats.loop_attempts,
                f.relocated, f.worst, f.along, maxTranslationError(r));
  };
  print("check off", off, f_off);
  print("check on ", on, f_on);
  // Achieved: off, one cluster 7.06 m wrong (one period), the end 6.96 m short along the
  // leg; on, 3 clusters refused and 3 closures relocated, the worst of 25 closures 0.06 m
  // off, the end 0.01 m along. (The largest error anywhere is no better, 12.6 m against
  // 7.0: the optimiser spreads the 7 m correction by bending the legs across, the weakness
  // noted in LoopClosureCorrectsDrift; so it is not asserted.)
  // Without the check a cluster one period off goes in, and the end is a period off.
  EXPECT_GE(off.stats.loop_clusters, 1u);
  EXPECT_GT(f_off.worst, 0.7 * period);
  EXPECT_GT(std::abs(f_off.along), 0.7 * period);
  // With it the wrong clusters are refused, the newest closures moved to the true place,
  // and every closure that goes in is right.
  EXPECT_GE(on.stats.loop_clusters_ambiguous, 1u);
  EXPECT_GE(on.stats.loop_clusters, 1u);
  EXPECT_GE(f_on.relocated, 1);
  EXPECT_GT(f_on.accepted, 10);
  EXPECT_LT(f_on.worst, 0.2);
  EXPECT_LT(std::abs(f_on.along), 0.5);
}

TEST(FloorSlam, ALoneClosureNeedsAUniquePlaceWhileTheGraphIsLost) {
  // A 60 m x 14 m ring whose bottom leg has pillars every 2.5 m on both walls from x = 10 on
  // (no irregularity). The top leg is bare and the wheels slip there the other way: odometry
  // says 6 % less than was driven, so back at the bottom-left corner the graph has the robot
  // about one period (2.5 m) ahead along the bottom leg, with σ near 5 m: the closures'
  // window is at its cap (4 m), and both the true place and the look-alike one period on lie
  // in it. The match near the graph's prediction is the look-alike, a small correction,
  // which goes in alone and confirms the wrong place. With single_unique_distance the other
  // place in the window holds it for a cluster, and the closures that follow, at the true
  // place, close the loop together.
  const double period = 2.5;
  const test::World world = ringWithPillars(period, 10.0);
  const auto truth = ringPath();
  const std::vector<Pose2> odometry = slipOnTopLeg(truth, 0.94);
  auto run = [&](double unique_distance) {
    FloorSlamOptions options = test::bareOptions();  // max_linear_window 4 m, the region check on
    options.loop_closure.cluster_verify_window = 30.0;
    options.loop_closure.single_unique_distance = unique_distance;
    return runWorld(world, truth, options, odometry);
  };
  struct Figures {
    int accepted = 0, not_unique = 0;
    double worst = 0.0;  // largest error of an accepted closure against the truth (m)
    // The worst closure that went in alone while the window was at its cap.
    double capped_alone = 0.0, capped_alone_sigma = 0.0, capped_alone_correction = 0.0;
    double along = 0.0;  // where the robot ended along the bottom leg relative to its start, error (m)
  };
  const double cap = test::bareOptions().loop_closure.max_linear_window;
  auto figures = [&](const WorldRun& r) {
    Figures f;
    for (const auto& a : r.attempts) {
      f.not_unique += a.not_unique ? 1 : 0;
      if (a.outcome != LoopOutcome::kAccepted) continue;
      ++f.accepted;
      const double e = closureError(r, a);
      f.worst = std::max(f.worst, e);
      if (a.together == 1 && a.linear_window >= cap && e > f.capped_alone) {
        f.capped_alone = e;
        f.capped_alone_sigma = a.sigma;
        f.capped_alone_correction = a.correction().translation().norm();
      }
    }
    f.along = endAlongError(r);
    return f;
  };
  const WorldRun off = run(0.0), on = run(1.0);
  const Figures f_off = figures(off), f_on = figures(on);
  auto print = [](const char* name, const WorldRun& r, const Figures& f) {
    std::printf("%s: closures %d of %zu (clusters %zu), not unique %d, worst closure %.2f m; worst alone at the "
                "cap %.2f m (sigma %.2f m, correction %.2f m); end along %.2f m, max error %.2f m\n",
                name, f.accepted, r.stats.loop_attempts, r.stats.loop_clusters, f.not_unique, f.worst,
                f.capped_alone, f.capped_alone_sigma, f.capped_alone_correction, f.along, maxTranslationError(r));
  };
  print("unique check off", off, f_off);
  print("unique check on ", on, f_on);
  // Achieved: off, a closure at the corner went in alone 2.51 m (one period) wrong with a
  // 0.08 m correction at σ 4.80 m, and the rest followed it (37 closures, all alone, the worst
  // 2.55 m off, the end 2.51 m along); on, that closure was held (1 not unique), the next
  // three, at the true place, went in as a cluster, the worst of 36 closures 0.04 m off, the
  // end 0.01 m along. (The largest error anywhere is worse, 6.06 m against 2.83: the optimiser
  // spreads the 2.5 m correction by bending the legs across, the weakness noted in
  // LoopClosureCorrectsDrift; so it is not asserted.) The world is narrow: with 6.5 % slip
  // instead of 6 % nothing in the window scores 0.9 of the match and the wrong closure goes in
  // with the check on too (5.5 %, or seed 6, behave as here).
  EXPECT_GT(f_off.capped_alone, 0.7 * period);
  EXPECT_GE(f_off.capped_alone_sigma, 1.0);  // 1 m + 3σ >= 4 m: the window at its cap
  EXPECT_LE(f_off.capped_alone_correction, test::bareOptions().loop_closure.single_max_translation);
  EXPECT_GT(std::abs(f_off.along), 0.7 * period);
  EXPECT_EQ(off.stats.loop_clusters, 0u);
  EXPECT_GE(f_on.not_unique, 1);
  EXPECT_GE(on.stats.loop_clusters, 1u);
  EXPECT_GT(f_on.accepted, 10);
  EXPECT_LT(f_on.worst, 0.5);
  EXPECT_LT(std::abs(f_on.along), 0.5);
}

TEST(FloorSlamOptions, TheShippedFileIsTheLibrarysDefaults) {
  const auto root = common::ConfigNode::loadFile(storey::test::sourceDir() + "/config/floor_mapper.yaml");
  const FloorSlamOptions shipped = readFloorSlamOptions(root.child("slam"));
  const FloorSlamOptions defaults;
  EXPECT_DOUBLE_EQ(shipped.laser.range_noise, defaults.laser.range_noise);
  EXPECT_DOUBLE_EQ(shipped.odometry.translation_per_meter, defaults.odometry.translation_per_meter);
  EXPECT_DOUBLE_EQ(shipped.odometry.rotation_per_meter, defaults.odometry.rotation_per_meter);
  EXPECT_DOUBLE_EQ(shipped.odometry.rotation_per_radian, defaults.odometry.rotation_per_radian);
  EXPECT_DOUBLE_EQ(shipped.local_map.resolution, defaults.local_map.resolution);
  EXPECT_DOUBLE_EQ(shipped.node.min_translation, defaults.node.min_translation);
  EXPECT_DOUBLE_EQ(shipped.node.min_rotation, defaults.node.min_rotation);
  EXPECT_EQ(shipped.local_map.max_nodes, defaults.local_map.max_nodes);
  EXPECT_EQ(shipped.loop_closure.enabled, defaults.loop_closure.enabled);
  EXPECT_EQ(shipped.relocalization.known_floor, defaults.relocalization.known_floor);
  EXPECT_EQ(shipped.relocalization.global.seed, defaults.relocalization.global.seed);
  EXPECT_DOUBLE_EQ(shipped.matcher.min_point_stddev, defaults.matcher.min_point_stddev);
  EXPECT_DOUBLE_EQ(shipped.loop_closure.point_polish_translation,
                   defaults.loop_closure.point_polish_translation);
}

TEST(FloorSlamOptions, TheLaserModelSetsTheNoiseFloors) {
  const FloorSlamOptions real =
      readFloorSlamOptions(common::ConfigNode::loadString("laser: {range_noise: 0.04}\n"));
  EXPECT_DOUBLE_EQ(real.matcher.min_point_stddev, 0.02);
  EXPECT_DOUBLE_EQ(real.matcher.min_translation_stddev, 0.01);
  EXPECT_DOUBLE_EQ(real.loop_closure.point_polish_translation, 0.0);  // points no finer than cells
  // A precise laser: finer floors, and closures polished on the map's points.
  const FloorSlamOptions clean =
      readFloorSlamOptions(common::ConfigNode::loadString("laser: {range_noise: 0.01}\n"));
  EXPECT_DOUBLE_EQ(clean.matcher.min_point_stddev, 0.005);
  EXPECT_DOUBLE_EQ(clean.loop_closure.matcher.min_point_stddev, 0.005);
  EXPECT_DOUBLE_EQ(clean.matcher.min_translation_stddev, 0.0025);
  EXPECT_DOUBLE_EQ(clean.loop_closure.point_polish_translation, 0.05);
  // The resolution sets the point filter and cells.
  const FloorSlamOptions fine =
      readFloorSlamOptions(common::ConfigNode::loadString("map_resolution: 0.025\n"));
  EXPECT_DOUBLE_EQ(fine.local_map.point_cell_size, 0.025);
  EXPECT_DOUBLE_EQ(fine.matcher.point_filter_distance, 0.025);
}

TEST(FloorSlamOptions, KeysAreReadStrictly) {
  auto read = [](const std::string& text) {
    return readFloorSlamOptions(common::ConfigNode::loadString(text));
  };
  EXPECT_EQ(read("local_map_nodes: 7\n").local_map.max_nodes, 7);
  EXPECT_FALSE(read("loop_closure: false\n").loop_closure.enabled);
  EXPECT_EQ(read("relocalization: {known_floor: new_graph, seed: 4}\n").relocalization.global.seed,
            4u);
  EXPECT_THROW(read("local_map_nodes: 1\n"), common::ConfigError);
  EXPECT_THROW(read("node_spacing: {translaton: 1}\n"), common::ConfigError);
  EXPECT_THROW(read("laser: {range_noise: 0}\n"), common::ConfigError);
  EXPECT_THROW(read("scan_matcher: {min_score: 0.3}\n"), common::ConfigError);
  EXPECT_THROW(read("relocalization: {known_floor: guess}\n"), common::ConfigError);
  EXPECT_THROW(read("bogus: 1\n"), common::ConfigError);
}

}  // namespace
}  // namespace storey::mapping
