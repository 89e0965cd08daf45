// Evaluation against reference poses (eval/slam_evaluation.h): edge consistency, the
// relation error with left-out poses, and the check of reference poses against their scans.
#include "storey/eval/slam_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include "synthetic_world.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;
using namespace eval;  // NOLINT(google-build-using-namespace): the evaluation under test

TEST(EdgeConsistency, NormalisesEachKindsErrorByItsInformation) {
  floor::FloorGraph graph;
  const std::map<int, Pose2> truth = {{0, Pose2(0, 0, 0)}, {1, Pose2(1, 0, 0.5)}, {2, Pose2(1, 1, 1.0)}};
  auto edge = [&](int from, int to, const Pose2& error, double sigma, floor::EdgeKind kind) {
    floor::FloorEdge e;
    e.from = from;
    e.to = to;
    e.measurement = truth.at(from).between(truth.at(to)) * error;
    e.information = Eigen::Vector3d(1 / (sigma * sigma), 1 / (sigma * sigma), 1 / (sigma * sigma)).asDiagonal();
    e.kind = kind;
    graph.edges.push_back(e);
  };
  edge(0, 1, Pose2(0.02, 0.0, 0.0), 0.01, floor::EdgeKind::kScanMatch);  // NEES 4
  edge(1, 2, Pose2(0.0, 0.0, 0.03), 0.01, floor::EdgeKind::kScanMatch);  // NEES 9
  edge(0, 1, Pose2(0.0, 0.1, 0.0), 0.1, floor::EdgeKind::kOdometry);     // NEES 1
  floor::FloorEdge unknown;  // node 5 has no reference pose: left out
  unknown.from = 0;
  unknown.to = 5;
  unknown.kind = floor::EdgeKind::kLoopClosure;
  graph.edges.push_back(unknown);
  const auto result = edgeConsistency(graph, truth);
  ASSERT_EQ(result.size(), 2u);
  EXPECT_EQ(result[0].kind, floor::EdgeKind::kOdometry);
  EXPECT_EQ(result[0].count, 1u);
  EXPECT_NEAR(result[0].mean_nees, 1.0, 1e-9);
  EXPECT_NEAR(result[0].rms_translation_error, 0.1 / std::sqrt(2.0), 1e-9);  // per axis
  EXPECT_NEAR(result[0].rms_translation_sigma, 0.1, 1e-9);
  EXPECT_EQ(result[1].kind, floor::EdgeKind::kScanMatch);
  EXPECT_EQ(result[1].count, 2u);
  EXPECT_NEAR(result[1].mean_nees, 6.5, 1e-9);
  EXPECT_NEAR(result[1].rms_rotation_error, 0.03 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(result[1].rms_rotation_sigma, 0.01, 1e-9);
}

// A graph whose odometry edges are simulateOdometry's steps along a random walk, with the walk
// as the nodes' poses.
floor::FloorGraph odometryGraph(const std::vector<Pose2>& truth, const OdometryNoise& noise,
                                std::uint64_t seed, std::map<int, Pose2>* poses) {
  const std::vector<Pose2> odometry = simulateOdometry(truth, noise, seed);
  floor::FloorGraph graph;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    (*poses)[static_cast<int>(i)] = truth[i];
    if (i == 0) continue;
    floor::FloorEdge e;
    e.from = static_cast<int>(i - 1);
    e.to = static_cast<int>(i);
    e.measurement = odometry[i - 1].between(odometry[i]);
    e.kind = floor::EdgeKind::kOdometry;
    graph.edges.push_back(e);
  }
  return graph;
}

std::vector<Pose2> randomWalk(std::size_t steps, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> length(0.05, 1.2), turn(-0.8, 0.8);
  std::vector<Pose2> walk{Pose2()};
  for (std::size_t i = 1; i < steps; ++i) {
    const double d = length(rng), t = turn(rng);
    walk.push_back(walk.back() * Pose2(d, 0.0, t));
  }
  return walk;
}

TEST(OdometryNoiseFit, FindsTheRatesTheOdometryWasDrawnWith) {
  // Three models, each term on its own and all together; 4000 steps are enough to tell each
  // rate within 10 %.
  const std::vector<Pose2> walk = randomWalk(4000, 3);
  for (const OdometryNoise& noise :
       {OdometryNoise{0.05, 2.0 * M_PI / 180.0, 0.02}, OdometryNoise{0.1, 0.0, 0.2},
        OdometryNoise{0.02, 0.05, 0.0}}) {
    std::map<int, Pose2> poses;
    const floor::FloorGraph graph = odometryGraph(walk, noise, 7, &poses);
    OdometryNoiseModel floors;
    floors.min_translation_stddev = floors.min_rotation_stddev = 1e-6;  // out of the way
    const OdometryNoiseFit fit = fitOdometryNoise(graph, poses, floors);
    EXPECT_EQ(fit.steps, 3999u);
    std::printf("drawn %.4f %.4f %.4f, fitted %.4f %.4f %.4f\n", noise.translation_fraction,
                noise.rotation_per_meter, noise.rotation_fraction, fit.model.translation_per_meter,
                fit.model.rotation_per_meter, fit.model.rotation_per_radian);
    const auto near = [](double fitted, double drawn) {
      return drawn == 0.0 ? fitted < 0.003 : std::abs(fitted - drawn) < 0.1 * drawn;
    };
    EXPECT_PRED2(near, fit.model.translation_per_meter, noise.translation_fraction);
    EXPECT_PRED2(near, fit.model.rotation_per_meter, noise.rotation_per_meter);
    EXPECT_PRED2(near, fit.model.rotation_per_radian, noise.rotation_fraction);
    EXPECT_EQ(fit.model.min_translation_stddev, floors.min_translation_stddev);
  }
}

TEST(OdometryNoiseFit, OnlyOdometryEdgesWithBothPosesCount) {
  const std::vector<Pose2> walk = randomWalk(200, 5);
  std::map<int, Pose2> poses;
  floor::FloorGraph graph = odometryGraph(walk, OdometryNoise{}, 2, &poses);
  const OdometryNoiseFit all = fitOdometryNoise(graph, poses);
  // A scan-match edge 1 m off and an odometry edge to a node without a pose change nothing.
  floor::FloorEdge match;
  match.from = 0, match.to = 1, match.kind = floor::EdgeKind::kScanMatch;
  match.measurement = Pose2(5.0, 0.0, 1.0);
  floor::FloorEdge dangling;
  dangling.from = 199, dangling.to = 200, dangling.kind = floor::EdgeKind::kOdometry;
  dangling.measurement = Pose2(3.0, 0.0, 0.0);
  graph.edges.push_back(match);
  graph.edges.push_back(dangling);
  const OdometryNoiseFit more = fitOdometryNoise(graph, poses);
  EXPECT_EQ(all.steps, 199u);
  EXPECT_EQ(more.steps, 199u);
  EXPECT_EQ(more.model.translation_per_meter, all.model.translation_per_meter);
  EXPECT_EQ(more.model.rotation_per_radian, all.model.rotation_per_radian);
  // No odometry edge at all: nothing fitted, the floors' model back.
  OdometryNoiseModel floors;
  floors.translation_per_meter = 0.123;
  const OdometryNoiseFit none = fitOdometryNoise(floor::FloorGraph{}, poses, floors);
  EXPECT_EQ(none.steps, 0u);
  EXPECT_EQ(none.model.translation_per_meter, 0.123);
}

TEST(RelationErrors, PairsWithALeftOutPoseAreNotCounted) {
  std::vector<Pose2> reference, estimate;
  for (int i = 0; i < 6; ++i) reference.emplace_back(i, 0.0, 0.0);
  estimate = reference;
  estimate[2] = Pose2(2.0, 0.1, 0.2);  // wrong: pairs (1, 2) and (2, 3) are off
  const RelationErrors all = relationErrors(estimate, reference, 10.0, 100);
  EXPECT_EQ(all.nearby.count, 5u);
  EXPECT_GT(all.nearby.rotation_mean, 0.05);
  std::vector<bool> left_out(reference.size(), false);
  left_out[2] = true;
  const RelationErrors checked = relationErrors(estimate, reference, 10.0, 100, 1, left_out);
  EXPECT_EQ(checked.nearby.count, 3u);
  EXPECT_NEAR(checked.nearby.translation_mean, 0.0, 1e-12);
  EXPECT_NEAR(checked.nearby.rotation_mean, 0.0, 1e-12);
  EXPECT_THROW(relationErrors(estimate, reference, 10.0, 100, 1, std::vector<bool>(3, false)),
               std::invalid_argument);
}

// A walk through the office, scans ray-cast at the true poses.
std::vector<Pose2> officeWalk() {
  std::vector<Pose2> poses;
  for (int i = 0; i < 24; ++i) poses.emplace_back(1.0 + 0.4 * i, 4.0 + 0.03 * i, 0.3 + 0.05 * i);
  return poses;
}

TEST(ReferenceCheck, FindsTheReferencePosesTheirScansContradictAndNoOther) {
  const test::World world = test::officeWorld();
  const std::vector<Pose2> truth = officeWalk();
  std::vector<sensor::LaserScan> scans;
  for (std::size_t i = 0; i < truth.size(); ++i) scans.push_back(world.scan(truth[i], static_cast<double>(i)));
  std::vector<Pose2> reference = truth;
  reference[8] = truth[8] * Pose2(0.0, 0.0, 12.0 * M_PI / 180.0);  // a reference 12° off
  reference[16] = truth[16] * Pose2(0.25, -0.2, 0.0);              // and one 0.32 m off
  const std::vector<ReferencePoseCheck> checks = checkReferencePoses(scans, reference);
  ASSERT_EQ(checks.size(), truth.size());
  for (const auto& c : checks) {
    SCOPED_TRACE("scan " + std::to_string(c.index));
    const bool corrupted = c.index == 8 || c.index == 16;
    EXPECT_EQ(c.contradicted, corrupted) << "score at the reference " << c.reference_score << ", at the match "
                                         << c.match_score;
    ASSERT_TRUE(c.matched);
    if (!corrupted) continue;
    // Where the reference is wrong, the match finds the true pose.
    const Pose2 error = truth[c.index].between(c.match);
    EXPECT_LT(error.translation().norm(), 0.05);
    EXPECT_LT(std::abs(error.theta()), 1.0 * M_PI / 180.0);
  }
}

TEST(ReferenceCheck, AReferenceMovedAlongABareCorridorIsNotContradicted) {
  // The scans cannot tell where along the corridor they were taken, so they cannot
  // contradict a reference pose moved along it.
  const test::World world = test::corridorWorld();
  std::vector<Pose2> truth;
  for (int i = 0; i < 12; ++i) truth.emplace_back(0.5 * i, 0.0, 0.0);
  std::vector<sensor::LaserScan> scans;
  for (std::size_t i = 0; i < truth.size(); ++i) scans.push_back(world.scan(truth[i], static_cast<double>(i)));
  std::vector<Pose2> reference = truth;
  reference[6] = truth[6] * Pose2(0.3, 0.0, 0.0);
  for (const auto& c : checkReferencePoses(scans, reference)) EXPECT_FALSE(c.contradicted) << "scan " << c.index;
}

TEST(SimulatedOdometry, SystematicErrorsScaleAndTurnEveryStep) {
  std::vector<Pose2> line;
  for (int i = 0; i <= 10; ++i) line.emplace_back(i, 0, 0);
  OdometryNoise exact{0.0, 0.0, 0.0};
  exact.scale = 1.03;
  exact.heading_drift_per_meter = 0.01;
  const std::vector<Pose2> odometry = simulateOdometry(line, exact, 1);
  ASSERT_EQ(odometry.size(), line.size());
  for (std::size_t i = 1; i < odometry.size(); ++i) {
    const Pose2 step = odometry[i - 1].between(odometry[i]);
    EXPECT_NEAR(step.x(), 1.03, 1e-12);
    EXPECT_NEAR(step.theta(), 0.01, 1e-12);
  }
}

TEST(SimulatedOdometry, AStallHoldsThePoseThenCatchesUpAndLeavesTheRestAlone) {
  std::vector<Pose2> line;
  for (int i = 0; i <= 40; ++i) line.emplace_back(0.25 * i, 0, 0);
  OdometryNoise noisy;
  OdometryNoise stalling = noisy;
  stalling.stall_every = 4.0;
  stalling.stall_length = 1.0;
  const std::vector<Pose2> plain = simulateOdometry(line, noisy, 3);
  const std::vector<Pose2> stalled = simulateOdometry(line, stalling, 3);
  int held = 0;
  for (std::size_t i = 1; i < line.size(); ++i) {
    const bool same = stalled[i].x() == stalled[i - 1].x() && stalled[i].y() == stalled[i - 1].y();
    if (same) {
      ++held;
      continue;
    }
    // Outside a stall, and where it catches up, the odometry is the stall-free one.
    EXPECT_EQ(stalled[i].x(), plain[i].x()) << i;
    EXPECT_EQ(stalled[i].theta(), plain[i].theta()) << i;
  }
  // Stalls at 4 m and 8 m of 10 m, each held for 1 m (4 steps of 0.25 m, the last of them
  // catching up).
  EXPECT_EQ(held, 6);
}

TEST(ThinnedIndices, KeepAPoseOnceItMovedOrTurnedEnough) {
  const std::vector<Pose2> poses = {Pose2(0, 0, 0),     Pose2(0.3, 0, 0),   Pose2(0.6, 0, 0),
                                    Pose2(0.6, 0, 0.4), Pose2(0.6, 0, 1.1), Pose2(1.7, 0, 1.1)};
  EXPECT_EQ(thinnedIndices(poses, 0.5, 0.5), (std::vector<std::size_t>{0, 2, 4, 5}));
  EXPECT_EQ(thinnedIndices(poses, 0.0, 0.0).size(), poses.size());
}

TEST(DegradeScan, CutsRangesDropsBeamsAddsNoiseAndNarrowsTheView) {
  sensor::LaserScan scan;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 180;
  scan.range_min = 0.1;
  scan.range_max = 30.0;
  for (int i = 0; i <= 180; ++i) scan.ranges.push_back(i % 2 ? 2.0f : 6.0f);
  std::mt19937_64 rng(1);
  LaserDegradation cut;
  cut.max_range = 3.5;
  const sensor::LaserScan short_range = degradeScan(scan, cut, rng);
  EXPECT_EQ(short_range.countReturns(), 90u);  // the 6 m readings are gone
  EXPECT_DOUBLE_EQ(short_range.range_max, 3.5);
  LaserDegradation half;
  half.beam_step = 2;
  EXPECT_EQ(degradeScan(scan, half, rng).size(), 91u);
  LaserDegradation narrow;
  narrow.field_of_view = M_PI / 2;
  const sensor::LaserScan view = degradeScan(scan, narrow, rng);
  EXPECT_EQ(view.size(), 91u);
  EXPECT_NEAR(view.angle_min, -M_PI / 4, 1e-9);
  LaserDegradation noise;
  noise.range_noise = 0.03;
  const sensor::LaserScan noisy = degradeScan(scan, noise, rng);
  double sum2 = 0.0;
  for (std::size_t i = 0; i < scan.size(); ++i)
    sum2 += std::pow(noisy.ranges[i] - scan.ranges[i], 2);
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(scan.size())), 0.03, 0.006);
}

}  // namespace
}  // namespace storey::mapping
