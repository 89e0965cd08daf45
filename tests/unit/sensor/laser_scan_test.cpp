#include "storey/sensor/laser_scan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace storey::sensor {
namespace {

LaserScan makeScan() {
  LaserScan scan;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 2;
  scan.range_min = 0.1;
  scan.range_max = 10.0;
  scan.ranges = {1.0f, 2.0f, 3.0f};
  return scan;
}

TEST(LaserScan, InvalidReturnsAreNotObstacles) {
  LaserScan scan = makeScan();
  scan.ranges = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                 0.05f, 10.0f, 12.0f, 5.0f};
  EXPECT_EQ(scan.countReturns(), 1u);
  EXPECT_FALSE(scan.isReturn(0));
  EXPECT_FALSE(scan.isReturn(3));  // exactly range_max means "nothing seen"
  EXPECT_TRUE(scan.isReturn(5));
}

TEST(LaserScan, PointsApplySensorOffsetAndRobotPose) {
  LaserScan scan = makeScan();
  scan.sensor_offset = geometry::Pose2(0.5, 0.0, 0.0);
  auto points = scan.pointsInRobotFrame();
  ASSERT_EQ(points.size(), 3u);
  EXPECT_NEAR(points[0].x(), 0.5, 1e-6);
  EXPECT_NEAR(points[0].y(), -1.0, 1e-6);
  EXPECT_NEAR(points[1].x(), 2.5, 1e-6);
  auto world = scan.pointsInWorld(geometry::Pose2(1, 1, M_PI / 2));
  EXPECT_NEAR(world[1].x(), 1.0, 1e-6);
  EXPECT_NEAR(world[1].y(), 3.5, 1e-6);
}

TEST(LaserScan, ValidateAndSubsample) {
  LaserScan scan = makeScan();
  EXPECT_EQ(scan.validate(), "");
  LaserScan bad = scan;
  bad.range_max = 0.0;
  EXPECT_NE(bad.validate(), "");
  bad = scan;
  bad.ranges.clear();
  EXPECT_NE(bad.validate(), "");
  LaserScan sub = subsample(scan, 2);
  ASSERT_EQ(sub.size(), 2u);
  EXPECT_DOUBLE_EQ(sub.angle(1), scan.angle(2));
}

TEST(LaserScan, BeamDirectionsFollowEachScansOwnAngles) {
  LaserScan a = makeScan();
  const auto first = a.beamDirections();
  ASSERT_EQ(first->size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ((*first)[i].x(), std::cos(a.angle(i)));
    EXPECT_EQ((*first)[i].y(), std::sin(a.angle(i)));
  }
  EXPECT_EQ(a.beamDirections(), first);  // the same sensor: the same table
  // Another sensor's scans (another start, increment or count) get their own.
  LaserScan b = makeScan();
  b.angle_min = 0.3;
  b.ranges.push_back(4.0f);
  const auto second = b.beamDirections();
  ASSERT_EQ(second->size(), 4u);
  EXPECT_EQ((*second)[3].x(), std::cos(b.angle(3)));
  EXPECT_EQ((*second)[3].y(), std::sin(b.angle(3)));
  // The first table stays valid for whoever still holds it.
  EXPECT_EQ((*first)[0].y(), std::sin(a.angle(0)));
  LaserScan c = makeScan();
  c.angle_increment = 0.1;
  EXPECT_EQ((*c.beamDirections())[2].y(), std::sin(c.angle(2)));
}

}  // namespace
}  // namespace storey::sensor

namespace storey::sensor {
namespace {

TEST(ImuSample, RotatedByYawTurnsBothVectorsAboutZ) {
  ImuSample s;
  s.linear_acceleration = Eigen::Vector3d(1.0, 0.0, 9.8);
  s.angular_velocity = Eigen::Vector3d(0.0, 0.2, 0.3);
  const ImuSample r = rotatedByYaw(s, M_PI / 2);
  EXPECT_NEAR((r.linear_acceleration - Eigen::Vector3d(0.0, 1.0, 9.8)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((r.angular_velocity - Eigen::Vector3d(-0.2, 0.0, 0.3)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace storey::sensor
