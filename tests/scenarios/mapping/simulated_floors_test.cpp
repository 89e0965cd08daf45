// The front end alone on the simulator's floors: each floor visit's scans with the
// simulated odometry, mapped by FloorSlam with the parameters `storey map` gives this
// robot (config/floor_mapper.yaml with its model's floor_mapper section on top), and
// compared with the ground truth by a similarity fit: a floor graph stretched or shrunk
// along its corridor misplaces every floor aligned to it (docs/floor_mapper.md,
// "Covariance floors"). STOREY_SCALE_SEEDS=N runs N seeds and prints each floor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

#include "storey/common/config.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_slam.h"
#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::mapping {
using eval::EdgeConsistency;
using eval::edgeConsistency;
namespace {

using geometry::Pose2;

struct FloorResult {
  int floor = 0;
  std::size_t nodes = 0;
  double scale = 1.0;         // estimated extent / true extent (similarity fit)
  double rms_residual = 0.0;  // m, after the best rigid fit
  std::vector<EdgeConsistency> edges;
};

Pose2 odometryAt(const std::vector<sensor::OdometrySample>& odometry, double stamp) {
  const auto after =
      std::lower_bound(odometry.begin(), odometry.end(), stamp,
                       [](const sensor::OdometrySample& s, double t) { return s.stamp < t; });
  if (after == odometry.begin()) return after->pose;
  if (after == odometry.end()) return odometry.back().pose;
  const auto before = after - 1;
  return geometry::interpolate(before->pose, after->pose,
                               (stamp - before->stamp) / (after->stamp - before->stamp));
}

void fitSimilarity(const std::vector<Pose2>& estimate, const std::vector<Pose2>& truth, FloorResult& r) {
  Eigen::Vector2d ce = Eigen::Vector2d::Zero(), ct = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    ce += estimate[i].translation();
    ct += truth[i].translation();
  }
  const double n = static_cast<double>(estimate.size());
  ce /= n;
  ct /= n;
  double c = 0, s = 0, ee = 0, tt = 0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const Eigen::Vector2d a = estimate[i].translation() - ce, b = truth[i].translation() - ct;
    c += a.dot(b);
    s += a.x() * b.y() - a.y() * b.x();
    ee += a.squaredNorm();
    tt += b.squaredNorm();
  }
  r.nodes = estimate.size();
  r.scale = std::hypot(s, c) / ee;
  r.rms_residual = std::sqrt(std::max(0.0, ee + tt - 2.0 * std::hypot(s, c)) / n);
}

// Every floor visit of the first robot mapped on its own (seconds around a transit left
// out: the robot is in a shaft).
std::vector<FloorResult> mapFloors(const sim::Simulation& run, const FloorSlamOptions& options) {
  const sim::RobotRun& robot = run.robots.at(0);
  auto inTransit = [&](double t) {
    for (const auto& transit : robot.transits)
      if (t >= transit.start - 1.0 && t <= transit.end + 1.0) return true;
    return false;
  };
  std::vector<FloorResult> results;
  std::size_t i = 0;
  int graph_id = 0;
  while (i < robot.scans.size()) {
    if (inTransit(robot.scans[i].stamp)) {
      ++i;
      continue;
    }
    const int floor = robot.truth[i].floor;
    FloorSlam slam(options, robot.name, graph_id++, floor, 0.0);
    std::map<int, Pose2> truth_by_node;
    for (; i < robot.scans.size() && robot.truth[i].floor == floor && !inTransit(robot.scans[i].stamp); ++i) {
      const ScanResult r = slam.addScan(robot.scans[i], odometryAt(robot.odometry, robot.scans[i].stamp));
      if (r.status == ScanStatus::kNode) truth_by_node[r.node_id] = robot.truth[i].pose;
    }
    slam.optimize();
    if (truth_by_node.size() < 10) continue;
    std::vector<Pose2> estimate, truth;
    for (const auto& [id, pose] : truth_by_node) {
      estimate.push_back(slam.poseGraph().node(id).pose);
      truth.push_back(pose);
    }
    FloorResult result;
    result.floor = floor;
    fitSimilarity(estimate, truth, result);
    result.edges = edgeConsistency(slam.floorGraph(), truth_by_node);
    results.push_back(result);
  }
  return results;
}

// The floor_mapper parameters `storey map` uses for this scenario's first robot.
FloorSlamOptions mapperOptionsFor(const sim::Scenario& scenario) {
  YAML::Node parameters =
      YAML::Clone(common::ConfigNode::loadFile(test::sourceDir() + "/config/floor_mapper.yaml").yaml());
  parameters["slam"]["laser"]["range_noise"] = scenario.robots.at(0).model.laser.range_sigma;
  return readFloorSlamOptions(common::ConfigNode(parameters, "floor_mapper", "").child("slam"));
}

TEST(SimulatedFloors, Tower10FloorGraphsKeepTheirScale) {
  const sim::Scenario scenario =
      sim::loadScenario(test::sourceDir() + "/config/buildings/tower10.yaml");
  const FloorSlamOptions options = mapperOptionsFor(scenario);
  const char* seeds_env = std::getenv("STOREY_SCALE_SEEDS");
  const int seeds = seeds_env ? std::max(1, std::atoi(seeds_env)) : 2;
  double sum_scale_error = 0.0, sum_scan_nees = 0.0;
  int floors = 0;
  for (int seed = 1; seed <= seeds; ++seed) {
    const sim::Simulation run = sim::simulate(scenario, static_cast<std::uint64_t>(seed));
    for (const FloorResult& f : mapFloors(run, options)) {
      double scan_nees = 0.0;
      for (const auto& e : f.edges)
        if (e.kind == floor::EdgeKind::kScanMatch) scan_nees = e.mean_nees;
      std::printf("seed %d F%d: %zu nodes, scale %.4f, rigid residual %.4f m, scan-match NEES %.2f\n", seed,
                  f.floor, f.nodes, f.scale, f.rms_residual, scan_nees);
      // 0.5 % over a 13.5 m floor is 3.4 cm at its ends: the floors aligned to it would
      // miss 0.05 m (issue #9).
      EXPECT_LT(std::abs(f.scale - 1.0), 0.005) << "seed " << seed << " F" << f.floor;
      EXPECT_LT(f.rms_residual, 0.02) << "seed " << seed << " F" << f.floor;
      sum_scale_error += std::abs(f.scale - 1.0);
      sum_scan_nees += scan_nees;
      ++floors;
    }
  }
  ASSERT_EQ(floors, 10 * seeds);
  // With the shipped file alone (covariance floors for real logs): mean 0.0024, NEES 0.08.
  EXPECT_LT(sum_scale_error / floors, 0.0018);
  EXPECT_GT(sum_scan_nees / floors, 0.3) << "the scan-match covariance is still far too wide for this laser";
}

// small2's robot with odometry that stalls for 2 s every 8 s on average (sim OdometryOptions).
// A stall during a turn in place holds the odometry while the robot turns, then catches up by
// 2.3 rad in one step. The scans in the stall are tracked beyond the odometry's window, and
// the one after it where the odometry's motion since it last agreed puts it; placed by
// odometry, or searched around the last pose alone, floor 0 broke (residual over 1 m).
TEST(SimulatedFloors, OdometryThatStallsDuringATurnIsCaughtUp) {
  sim::Scenario scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/small2.yaml");
  scenario.robots.at(0).model.odometry.stall_interval = 8.0;
  scenario.robots.at(0).model.odometry.stall_duration = 2.0;
  const sim::Simulation run = sim::simulate(scenario, 1);
  EXPECT_GT(run.robots.at(0).odometry_stalls, 10u);
  double worst_residual = 0.0;
  for (const FloorResult& f : mapFloors(run, mapperOptionsFor(scenario))) {
    std::printf("stalls F%d: %zu nodes, rigid residual %.3f m\n", f.floor, f.nodes, f.rms_residual);
    worst_residual = std::max(worst_residual, f.rms_residual);
  }
  EXPECT_LT(worst_residual, 0.05);
}

TEST(SimulatedFloors, FeaturelessCorridorKeepsItsLength) {
  // Floor B's 127 m corridor has nothing along its axis but its ends and a lobby: the
  // matches must leave that axis to the odometry. Before normal_tilt_stddev, noisy
  // normals claimed information along it: floor B came out 1.3 % long (residual 1.1 m),
  // 7 % with the robot model's finer covariance floor (2.9 m), with loop closures 5 m
  // off accepted.
  const sim::Scenario scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/featureless.yaml");
  const FloorSlamOptions options = mapperOptionsFor(scenario);
  const sim::Simulation run = sim::simulate(scenario, 1);
  const std::vector<FloorResult> floors = mapFloors(run, options);
  ASSERT_EQ(floors.size(), 2u);
  for (const FloorResult& f : floors) {
    std::printf("F%d: %zu nodes, scale %.4f, rigid residual %.4f m\n", f.floor, f.nodes, f.scale, f.rms_residual);
    for (const auto& e : f.edges)
      std::printf("  %-12s %4zu edges, NEES %.2f, rms error %.4f m, rms sigma %.4f m\n", floor::edgeKindName(e.kind),
                  e.count, e.mean_nees, e.rms_translation_error, e.rms_translation_sigma);
    EXPECT_LT(std::abs(f.scale - 1.0), 0.003) << "F" << f.floor;
    EXPECT_LT(f.rms_residual, 0.15) << "F" << f.floor;
    for (const auto& e : f.edges) EXPECT_LT(e.mean_nees, 3.0) << "F" << f.floor << " " << floor::edgeKindName(e.kind);
  }
}

// A robot turning and shuttling in a closed 2 m x 2 m room, as in an elevator cabin: every
// wall is within 1.4 m, so a match's heading rests on lever arms of a metre. Refined on
// the likelihood field, loop closures there come out about 1 deg off, all to one side;
// the point polish brings them to the noise. The closures' heading error is
// measured against the truth of both nodes.
TEST(SimulatedFloors, LoopClosuresInAnElevatorCabinKeepTheirHeading) {
  const std::string cabin = R"(
name: cabin
building:
  name: cabin
  floors:
    - id: F0
      height: 0
      walls:
        - {id: outer, rect: [[11, 7], [13, 9]]}
robots:
  - name: robot1
    model: default
    start: {floor: F0, pose: [12, 8, 90]}
    mission:
      - {go: [12, 7.6]}
      - {go: [12, 8.4]}
      - {go: [12, 7.6]}
      - {go: [12, 8.4]}
      - {go: [12.4, 8.0]}
      - {go: [11.6, 8.0]}
      - {go: [12.4, 8.0]}
)";
  const sim::Scenario scenario = sim::loadScenarioString(cabin, "cabin", test::sourceDir() + "/config/robots");
  const FloorSlamOptions polished = mapperOptionsFor(scenario);
  ASSERT_GT(polished.loop_closure.point_polish_translation, 0.0) << "the default robot model turns the polish on";
  FloorSlamOptions field = polished;
  field.loop_closure.point_polish_translation = 0.0;
  double squared[2] = {0.0, 0.0};
  std::size_t closures[2] = {0, 0};
  for (int seed = 1; seed <= 3; ++seed) {
    const sim::Simulation run = sim::simulate(scenario, static_cast<std::uint64_t>(seed));
    for (int k = 0; k < 2; ++k) {
      const std::vector<FloorResult> floors = mapFloors(run, k == 0 ? field : polished);
      ASSERT_EQ(floors.size(), 1u);
      for (const auto& e : floors[0].edges) {
        if (e.kind != floor::EdgeKind::kLoopClosure) continue;
        std::printf("seed %d, %s: %zu closures, rms heading error %.3f deg\n", seed,
                    k == 0 ? "field" : "polished", e.count, e.rms_rotation_error * 180.0 / M_PI);
        squared[k] += e.rms_rotation_error * e.rms_rotation_error * static_cast<double>(e.count);
        closures[k] += e.count;
      }
    }
  }
  ASSERT_GE(closures[0], 15u);
  ASSERT_GE(closures[1], 15u);
  const double field_rms = std::sqrt(squared[0] / static_cast<double>(closures[0])) * 180.0 / M_PI;
  const double polished_rms = std::sqrt(squared[1] / static_cast<double>(closures[1])) * 180.0 / M_PI;
  std::printf("closures' rms heading error: field %.3f deg, polished %.3f deg\n", field_rms, polished_rms);
  EXPECT_LT(polished_rms, 0.5);
  EXPECT_LT(polished_rms, 0.75 * field_rms);
}

}  // namespace
}  // namespace storey::mapping
