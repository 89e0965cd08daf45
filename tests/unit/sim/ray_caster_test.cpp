#include "storey/sim/ray_caster.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "storey/sim/random.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"

namespace storey::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(RayCaster, HitsAWallAtTheHandComputedDistance) {
  RayCaster caster({{{5.0, -10.0}, {5.0, 10.0}}});
  EXPECT_DOUBLE_EQ(caster.cast({0.0, 0.0}, {1.0, 0.0}, 30.0), 5.0);
  // 45 degrees: the hypotenuse.
  const Eigen::Vector2d diagonal(std::sqrt(0.5), std::sqrt(0.5));
  EXPECT_NEAR(caster.cast({0.0, 0.0}, diagonal, 30.0), 5.0 * std::sqrt(2.0), 1e-12);
  // Away from the wall, and beyond the maximum range: no return.
  EXPECT_TRUE(std::isinf(caster.cast({0.0, 0.0}, {-1.0, 0.0}, 30.0)));
  EXPECT_TRUE(std::isinf(caster.cast({0.0, 0.0}, {1.0, 0.0}, 4.0)));
  // Past the wall's end: no return.
  EXPECT_TRUE(std::isinf(caster.cast({0.0, 0.0}, Eigen::Vector2d(1.0, 3.0).normalized(), 30.0)));
}

TEST(RayCaster, ReturnsTheNearestOfSeveralSegments) {
  RayCaster caster(
      {{{8.0, -1.0}, {8.0, 1.0}}, {{3.0, -1.0}, {3.0, 1.0}}, {{6.0, -1.0}, {6.0, 1.0}}});
  EXPECT_DOUBLE_EQ(caster.cast({0.0, 0.0}, {1.0, 0.0}, 30.0), 3.0);
  EXPECT_DOUBLE_EQ(caster.cast({4.0, 0.0}, {1.0, 0.0}, 30.0), 2.0);
  EXPECT_DOUBLE_EQ(caster.cast({10.0, 0.5}, {-1.0, 0.0}, 30.0), 2.0);
}

TEST(RayCaster, GridAgreesWithBruteForceOnRandomRays) {
  Rng rng(7);
  std::vector<Segment> segments;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector2d a(rng.uniform(-20, 20), rng.uniform(-20, 20));
    const double angle = rng.uniform(0, 2 * kPi);
    segments.push_back(
        {a, a + rng.uniform(0.1, 6.0) * Eigen::Vector2d(std::cos(angle), std::sin(angle))});
  }
  RayCaster caster(segments, 0.7);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector2d origin(rng.uniform(-22, 22), rng.uniform(-22, 22));
    const double angle = rng.uniform(0, 2 * kPi);
    const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
    const double grid = caster.cast(origin, dir, 15.0);
    const double brute = caster.castBruteForce(origin, dir, 15.0);
    if (std::isinf(brute)) {
      EXPECT_TRUE(std::isinf(grid)) << "ray " << i;
    } else {
      ++hits;
      EXPECT_EQ(grid, brute) << "ray " << i;
    }
  }
  EXPECT_GT(hits, 5000);
}

TEST(CastScan, RangesInASquareRoomMatchHandComputation) {
  // A 10 m x 10 m room centred on the origin; the laser sits 0.5 m ahead of the robot.
  const std::vector<Segment> room = {
      {{-5, -5}, {5, -5}}, {{5, -5}, {5, 5}}, {{5, 5}, {-5, 5}}, {{-5, 5}, {-5, -5}}};
  LaserOptions laser;
  laser.fov = kPi;  // -90 .. +90 degrees
  laser.beams = 5;  // -90, -45, 0, 45, 90
  laser.max_range = 30.0;
  laser.offset = geometry::Pose2(0.5, 0.0, 0.0);
  const auto scan = castScan(room, laser, geometry::Pose2(1.0, 2.0, kPi / 2));  // facing +y
  ASSERT_EQ(scan.size(), 5u);
  // Sensor at (1, 2.5) facing +y. Beam 0 (-90 deg) looks along +x: 4 m.
  EXPECT_NEAR(scan.ranges[0], 4.0, 1e-5);
  EXPECT_NEAR(scan.ranges[1], 2.5 * std::sqrt(2.0), 1e-5);  // +x+y diagonal, hits y = 5
  EXPECT_NEAR(scan.ranges[2], 2.5, 1e-5);                   // straight ahead
  EXPECT_NEAR(scan.ranges[3], 2.5 * std::sqrt(2.0), 1e-5);  // -x+y diagonal, hits y = 5
  EXPECT_NEAR(scan.ranges[4], 6.0, 1e-5);                   // along -x
  // The scan's own geometry puts each endpoint on the wall.
  for (const auto& p : scan.pointsInWorld(geometry::Pose2(1.0, 2.0, kPi / 2)))
    EXPECT_NEAR(std::max(std::abs(p.x()), std::abs(p.y())), 5.0, 1e-5);
}

}  // namespace
}  // namespace storey::sim
