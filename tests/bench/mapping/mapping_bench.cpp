// Speed of the scan matcher's stages and of building a match target, on scans ray-cast in
// the synthetic office of the unit tests (361 beams, 20 m), and of the whole front end.
#include <benchmark/benchmark.h>

#include "storey/common/config.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_slam.h"
#include "storey/mapping/scan_matcher.h"
#include "synthetic_world.h"

namespace storey::mapping {
using eval::OdometryNoise;
using eval::runOffline;
using eval::simulateOdometry;
namespace {

using geometry::Pose2;

grid::OccupancyGrid officeMap() {
  const test::World world = test::officeWorld();
  grid::OccupancyGrid grid;
  for (const Pose2 p : {Pose2(4, 4, 0), Pose2(8, 3, 1.0), Pose2(6, 6.5, -2.0)}) grid.insertScan(world.scan(p, 0), p);
  return grid;
}

void BM_BuildMatchTarget(benchmark::State& state) {
  const grid::OccupancyGrid grid = officeMap();
  for (auto _ : state) {
    MatchTarget target(grid, grid::LikelihoodFieldOptions{}, static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(target.pyramidLevels());
  }
  state.counters["cells"] = static_cast<double>(grid.frame().cellCount());
}
BENCHMARK(BM_BuildMatchTarget)->Arg(5)->Arg(7)->Unit(benchmark::kMillisecond);

// Full match (correlative + refinement) with a window of range(0) cm and ±0.35 rad.
void BM_Match(benchmark::State& state) {
  const test::World world = test::officeWorld();
  const MatchTarget target(officeMap(), grid::LikelihoodFieldOptions{}, 7);
  const Pose2 truth(6, 4, 0.3);
  const auto points = filterPoints(world.scan(truth, 0).pointsInRobotFrame(), 0.05);
  ScanMatcher matcher;
  const double window = state.range(0) / 100.0;
  long candidates = 0;
  for (auto _ : state) {
    const MatchResult r = matcher.match(target, points, truth * Pose2(0.1, -0.08, 0.05), window, 0.35);
    candidates += r.candidates_scored;
    benchmark::DoNotOptimize(r.pose);
  }
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["bounds_per_match"] = static_cast<double>(candidates) / state.iterations();
}
BENCHMARK(BM_Match)->Arg(30)->Arg(150)->Arg(400)->Unit(benchmark::kMillisecond);

void BM_Refine(benchmark::State& state) {
  const test::World world = test::officeWorld();
  const MatchTarget target(officeMap(), grid::LikelihoodFieldOptions{}, 7);
  const Pose2 truth(6, 4, 0.3);
  const auto points = filterPoints(world.scan(truth, 0).pointsInRobotFrame(), 0.05);
  ScanMatcher matcher;
  for (auto _ : state) benchmark::DoNotOptimize(matcher.refine(target.field(), points, truth * Pose2(0.03, -0.02, 0.01)));
}
BENCHMARK(BM_Refine)->Unit(benchmark::kMicrosecond);

// The whole front end (tracking, loop closure, optimisation) over a ring corridor of 24 m x
// 16 m driven once and a half with 3 deg/m heading noise, with config/floor_mapper.yaml's
// options; range(0) = 1 turns on the loop closures' point polish (as the laser model does
// for a laser finer than half a cell; docs/floor_mapper.md). Figures:
// scans per second and closures accepted; the ratio of the two runs is the polish's cost.
void BM_FrontEndRing(benchmark::State& state) {
  const test::World world = test::ringCorridorWorld();
  const std::vector<Pose2> truth =
      test::pathThrough({{1, 1}, {23, 1}, {23, 15}, {1, 15}, {1, 1}, {23, 1}, {23, 15}});
  std::vector<sensor::LaserScan> scans;
  for (std::size_t i = 0; i < truth.size(); ++i) scans.push_back(world.scan(truth[i], 0.1 * static_cast<double>(i)));
  OdometryNoise noise;
  noise.rotation_per_meter = 3.0 * M_PI / 180;
  const std::vector<Pose2> odometry = simulateOdometry(truth, noise, 11);
  FloorSlamOptions options = readFloorSlamOptions(
      common::ConfigNode::loadFile(std::string(STOREY_SOURCE_DIR) + "/config/floor_mapper.yaml").child("slam"));
  if (state.range(0) == 1) {
    options.loop_closure.point_polish_translation = 0.05;
    options.loop_closure.point_polish_rotation = 0.03;
  }
  std::size_t closures = 0;
  for (auto _ : state) {
    FloorSlam slam(options, "robot", 0, 0, 0.0);
    benchmark::DoNotOptimize(runOffline(slam, scans, odometry).trajectory.size());
    closures = slam.stats().loop_closures;
  }
  state.counters["scans"] = static_cast<double>(scans.size());
  state.counters["closures"] = static_cast<double>(closures);
  state.counters["scans_per_s"] =
      benchmark::Counter(static_cast<double>(scans.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_FrontEndRing)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace storey::mapping

BENCHMARK_MAIN();
