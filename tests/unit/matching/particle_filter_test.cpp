#include "storey/localization/particle_filter.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <numeric>
#include <sstream>

#include "matching_test_helpers.h"
#include "storey/common/config.h"
#include "storey/eval/simulated_floors.h"
#include "storey/matching/constraint_judgement.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/retraction.h"
#include "synthetic_floor.h"
#include "test_support.h"

namespace storey::matching {
namespace {

using geometry::Pose2;
using localization::FilterState;
using localization::LocalizationMap;
using localization::makeWallModel;
using localization::ParticleFilter;
using localization::ParticleFilterOptions;
using localization::selectBeams;
using localization::WallModel;
using test::angleError;
using test::driveFloor;
using test::officeFloor;
using test::officePath;
using test::translationError;

TEST(ParticleFilter, UniformInitialisationIsInFreeSpaceAndSizedByArea) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 1);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilterOptions o;
  o.initial_particles_per_m2 = 10.0;
  ParticleFilter pf(map, o, 3);
  pf.initializeUniform();
  const double expected = std::clamp(map.freeArea() * 10.0, 300.0, 50000.0);
  EXPECT_NEAR(static_cast<double>(pf.size()), expected, 1.0);
  for (std::size_t j = 0; j < pf.size(); ++j) EXPECT_TRUE(map.isFree(pf.xs()[j], pf.ys()[j]));
  EXPECT_FALSE(pf.state().converged);
}

TEST(ParticleFilter, GlobalLocalisationConvergesToTheTruePoseAndShrinks) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 2);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilter pf(map, {}, 11);
  pf.initializeUniform();
  const std::size_t initial = pf.size();
  bool converged = false;
  for (std::size_t n = 0; n < 40 && n < g.nodes.size(); ++n) {
    if (n > 0) pf.predict(g.nodes[n - 1].odometry.between(g.nodes[n].odometry));
    pf.update(g.nodes[n].scan);
    const FilterState s = pf.state();
    if (n >= 2 && s.converged) {
      EXPECT_LT(translationError(s.mean, g.nodes[n].pose), 0.3) << "node " << n;
      EXPECT_LT(angleError(s.mean, g.nodes[n].pose), 0.1);
      converged = true;
      break;
    }
    pf.resampleIfNeeded();
  }
  EXPECT_TRUE(converged);
  EXPECT_LT(pf.size(), initial / 4) << "KLD-sampling should shrink a converged filter";
}

// Coarse-to-fine: the global phase with few beams must still converge to the truth, and
// use fewer particle-beam evaluations than the same filter with every beam.
TEST(ParticleFilter, CoarseBeamsInTheGlobalPhaseStillConverge) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 2);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  std::uint64_t evaluations[2] = {0, 0};
  for (int coarse = 0; coarse < 2; ++coarse) {
    ParticleFilterOptions o;
    o.initial_particles_per_m2 = 200.0;  // a global phase well above coarse_particles
    o.coarse_beams = coarse ? 15 : 0;
    o.coarse_particles = 2000;
    ParticleFilter pf(map, o, 11);
    pf.initializeUniform();
    ASSERT_GT(pf.size(), 2000u);
    bool converged = false;
    for (std::size_t n = 0; n < 40 && n < g.nodes.size(); ++n) {
      if (n > 0) pf.predict(g.nodes[n - 1].odometry.between(g.nodes[n].odometry));
      pf.update(g.nodes[n].scan);
      const FilterState s = pf.state();
      if (n >= 2 && s.converged) {
        EXPECT_LT(translationError(s.mean, g.nodes[n].pose), 0.3) << "coarse " << coarse;
        EXPECT_LT(angleError(s.mean, g.nodes[n].pose), 0.1) << "coarse " << coarse;
        converged = true;
        break;
      }
      pf.resampleIfNeeded();
    }
    EXPECT_TRUE(converged) << "coarse " << coarse;
    evaluations[coarse] = pf.beamEvaluations();
  }
  EXPECT_LT(evaluations[1], evaluations[0]);
}

TEST(ParticleFilter, LikelihoodIsHigherAtTheTruePose) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 3);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilter right(map, {}, 1), wrong(map, {}, 1);
  const Pose2 truth = g.nodes[10].pose;
  right.initializeAround(truth, 0.0, 0.0, 10);
  wrong.initializeAround(truth * Pose2(0.0, 0.0, 0.5), 0.0, 0.0, 10);
  EXPECT_GT(right.update(g.nodes[10].scan), 2.0 * wrong.update(g.nodes[10].scan));
  EXPECT_EQ(right.beamEvaluations(), 10u * 60u);
}

// A 10 m x 5 m frame with one wall one cell thick at x = 5 m, from y = 1 to 4 m.
grid::GridFrame wallFrame(std::vector<std::uint8_t>* walls) {
  grid::GridFrame f;
  f.resolution = 0.05;
  f.width = 200;
  f.height = 100;
  walls->assign(f.cellCount(), 0);
  for (int cy = 20; cy < 80; ++cy) (*walls)[f.index(100, cy)] = 1;
  return f;
}

TEST(WallModel, FindsTheWallsASegmentCrossesAndNoOthers) {
  std::vector<std::uint8_t> walls;
  const grid::GridFrame f = wallFrame(&walls);
  const WallModel model = makeWallModel(f, walls);
  EXPECT_FLOAT_EQ(model.distance[f.index(100, 50)], 0.0f);
  EXPECT_NEAR(model.distance[f.index(90, 50)], 0.5, 0.05);  // chamfer, within 8 %
  EXPECT_TRUE(model.crosses({1.0, 2.5}, {8.0, 2.5}));
  EXPECT_FALSE(model.crosses({1.0, 2.5}, {4.9, 2.5}));  // stops short of it
  EXPECT_FALSE(model.crosses({1.0, 0.5}, {8.0, 0.5}));  // passes below its end
  EXPECT_FALSE(model.crosses({5.5, 2.5}, {9.5, 4.5}));  // starts beyond it
  EXPECT_TRUE(model.crosses({9.0, 3.9}, {1.0, 1.1}));   // diagonal, right to left
  // Every segment through the wall's middle at up to 60 degrees from its normal, with
  // random ends in open space on both sides, is caught (sphere tracing must not step over
  // a wall one cell thick).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> y(1.8, 3.2), angle(-1.05, 1.05), length(0.3, 4.5);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d at(5.025, y(rng));
    const double a = angle(rng);
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    const Eigen::Vector2d from = at - std::min(length(rng), 4.9 / u.x()) * u;
    const Eigen::Vector2d to = at + std::min(length(rng), 4.9 / u.x()) * u;
    ASSERT_TRUE(model.crosses(from, to)) << "from " << from.transpose() << " to " << to.transpose();
  }
}

// One node's scan: beams over +-0.2 rad ending on the vertical line x = `wall_x` (robot at
// the origin, heading 0).
floor::FloorNode nodeSeeingWallAt(int id, double wall_x) {
  floor::FloorNode n;
  n.id = id;
  n.scan.angle_min = -0.2;
  n.scan.angle_increment = 0.002;  // dense enough that the mapped walls have no gaps
  n.scan.range_min = 0.05;
  n.scan.range_max = 30.0;
  for (int b = 0; b <= 200; ++b)
    n.scan.ranges.push_back(static_cast<float>(wall_x / std::cos(n.scan.angle(b))));
  return n;
}

TEST(SolidWalls, AWallTheFloorsOwnBeamsPassedIsNotSolid) {
  // A door at x = 2 m, shut for three scans and open for one (which sees the wall at 4 m).
  floor::FloorGraph g;
  for (int i = 0; i < 3; ++i) g.nodes.push_back(nodeSeeingWallAt(i, 2.0));
  g.nodes.push_back(nodeSeeingWallAt(3, 4.0));
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  const grid::GridFrame& f = map.frame();
  const Eigen::Vector2i door = f.cellOf({2.02, 0.0}), far = f.cellOf({4.02, 0.0});
  ASSERT_FLOAT_EQ(map.field().distance().at(door.x(), door.y()), 0.0f) << "the door is mapped";
  const std::vector<std::uint8_t> walls = solidWalls(map.field(), g, 90);
  EXPECT_EQ(walls[f.index(door.x(), door.y())], 0);
  EXPECT_EQ(walls[f.index(far.x(), far.y())], 1);
  // Seen from 1 m further on, the open-door scan sees through no solid wall; put 3 m
  // back, it would (its beams end 1 m beyond the far wall).
  EXPECT_DOUBLE_EQ(seeThroughFraction(f, walls, g, {{3, 3}}, 90, Pose2(), 0.3), 0.0);
  EXPECT_GT(seeThroughFraction(f, walls, g, {{3, 3}}, 90, Pose2(1.0, 0.0, 0.0), 0.3), 0.9);
}

TEST(ParticleFilter, WallModelLowersExactlyTheParticlesWhoseBeamsCrossWalls) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 3);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  const WallModel walls = makeWallModel(map.frame(), solidWalls(map.field(), g, 90));
  ParticleFilterOptions o;
  o.initial_particles_per_m2 = 5.0;
  ParticleFilter plain(map, o, 21), with_walls(map, o, 21);
  const int traced = 12;
  const double log_p = -10.0, margin = 0.3;
  with_walls.setWallModel(&walls, traced, log_p, margin);
  plain.initializeUniform();
  with_walls.initializeUniform();
  const sensor::LaserScan& scan = g.nodes[7].scan;
  plain.update(scan);
  with_walls.update(scan);
  ASSERT_EQ(plain.size(), with_walls.size());
  // Per particle: log(w_walls / w_plain) = constant + effective_beams * log_p * (fraction
  // of the traced beams crossing a wall).
  const std::vector<Eigen::Vector2d> beams = selectBeams(scan, traced);
  double offset = std::numeric_limits<double>::quiet_NaN();
  int crossing_particles = 0, checked = 0;
  for (std::size_t j = 0; j < plain.size(); ++j) {
    const double wp = plain.weights()[j], ww = with_walls.weights()[j];
    const Pose2 pose(plain.xs()[j], plain.ys()[j], plain.thetas()[j]);
    const Eigen::Vector2d origin = pose.transformPoint(scan.sensor_offset.translation());
    int crossed = 0;
    for (const auto& b : beams) {
      const Eigen::Vector2d d = b - scan.sensor_offset.translation();
      const Eigen::Vector2d stop =
          scan.sensor_offset.translation() + d * ((d.norm() - margin) / d.norm());
      crossed += walls.crosses(origin, pose.transformPoint(stop));
    }
    crossing_particles += crossed > 0;
    if (wp < 1e-250 || ww < 1e-250) continue;
    const double expected = o.effective_beams * log_p * crossed / static_cast<double>(beams.size());
    const double ratio = std::log(ww / wp) - expected;
    if (std::isnan(offset)) offset = ratio;
    EXPECT_NEAR(ratio, offset, 1e-6) << "particle " << j << " crossed " << crossed;
    ++checked;
  }
  EXPECT_GT(crossing_particles, 0);
  EXPECT_GT(checked, 10);
}
}  // namespace
}  // namespace storey::matching
