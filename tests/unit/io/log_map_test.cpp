#include "storey/io/log_map.h"

#include <gtest/gtest.h>

#include <cmath>

#include "storey/common/config.h"
#include "storey/grid/image.h"
#include "test_support.h"

namespace storey::io {
namespace {

// Ranges from a sensor at `pose` to the walls of the square [-5, 5]^2 (exact ray casting).
CarmenLaser roomScan(const geometry::Pose2& pose, double stamp) {
  CarmenLaser laser;
  laser.scan.ranges.resize(181);
  for (int i = 0; i < 181; ++i) {
    const double a = pose.theta() - M_PI / 2 + i * M_PI / 180;
    const double c = std::cos(a), s = std::sin(a);
    double t = 1e9;
    if (c > 1e-12) t = std::min(t, (5 - pose.x()) / c);
    if (c < -1e-12) t = std::min(t, (-5 - pose.x()) / c);
    if (s > 1e-12) t = std::min(t, (5 - pose.y()) / s);
    if (s < -1e-12) t = std::min(t, (-5 - pose.y()) / s);
    laser.scan.ranges[i] = static_cast<float>(t);
  }
  laser.laser_pose = pose;
  laser.odom_pose = geometry::Pose2(pose.x() + 1.0, pose.y(), pose.theta());  // odometry off by 1 m
  laser.scan.stamp = stamp;
  return laser;
}

std::string writeRoomLog() {
  const std::string path = test::makeTempDir("storey_io") + "/room.log.gz";
  CarmenWriter writer(path);
  for (int k = 0; k < 8; ++k) {
    const CarmenLaser laser = roomScan(geometry::Pose2(-2 + 0.5 * k, 0.3, k * M_PI / 4), k);
    writer.flaser(laser);
    writer.flaser(roomScan(geometry::Pose2(0, 0, 0), k), 2);  // a rear laser, drawn only on request
  }
  writer.close();
  return path;
}

grid::CellState stateAtWorld(const grid::OccupancyGrid& map, double x, double y) {
  const Eigen::Vector2i c = map.frame().cellOf({x, y});
  return map.stateAt(c.x(), c.y());
}

// A wall at exactly x = 5 puts its endpoints on either side of a cell border.
bool occupiedNear(const grid::OccupancyGrid& map, double x, double y) {
  const Eigen::Vector2i c = map.frame().cellOf({x, y});
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (map.stateAt(c.x() + dx, c.y() + dy) == grid::CellState::kOccupied) return true;
  return false;
}

TEST(MapFromLog, DrawsTheWallsAtTheCorrectedPoses) {
  const std::string path = writeRoomLog();
  LogMapOptions options;
  const LogMap map = mapFromLog(path, options);
  EXPECT_EQ(map.scans_inserted, 8u);
  EXPECT_EQ(map.stats.recordCount("RLASER"), 8u);
  EXPECT_EQ(stateAtWorld(map.grid, 0.0, 0.0), grid::CellState::kFree);
  EXPECT_TRUE(occupiedNear(map.grid, 5.0, 0.5));    // east wall
  EXPECT_TRUE(occupiedNear(map.grid, -1.0, -5.0));  // south wall
  EXPECT_FALSE(occupiedNear(map.grid, 4.0, 0.5));
  EXPECT_EQ(stateAtWorld(map.grid, 6.0, 0.5), grid::CellState::kUnknown);  // behind the wall
}

TEST(MapFromLog, OdometryPosesShiftTheMap) {
  LogMapOptions options;
  options.pose = LogPose::kOdometry;
  const LogMap map = mapFromLog(writeRoomLog(), options);
  // The odometry is 1 m east of the truth: the east wall lands at x = 6.
  EXPECT_TRUE(occupiedNear(map.grid, 6.0, 0.5));
  EXPECT_FALSE(occupiedNear(map.grid, 5.0, 0.5));
}

TEST(MapFromLog, SelectsLaserAndScanRange) {
  const std::string path = writeRoomLog();
  LogMapOptions options;
  options.laser_id = 0;
  EXPECT_EQ(mapFromLog(path, options).scans_inserted, 16u);
  options.laser_id = 2;
  EXPECT_EQ(mapFromLog(path, options).scans_inserted, 8u);
  options.laser_id = 1;
  options.first_scan = 3;
  options.max_scans = 2;
  EXPECT_EQ(mapFromLog(path, options).scans_inserted, 2u);
  options.first_scan = 7;
  options.max_scans = 0;
  EXPECT_EQ(mapFromLog(path, options).scans_inserted, 1u);
}

// Regression: the first 100 scans of the Intel lab, cell by cell against a crop drawn by
// storey earlier (tests/data/intel_first100.png with its nav2 YAML).
TEST(MapFromLog, IntelFirstHundredScansMatchTheCommittedCrop) {
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  const std::string yaml_path = test::sourceDir() + "/tests/data/intel_first100.yaml";
  auto yaml = common::ConfigNode::loadFile(yaml_path);
  const std::string image_name = yaml.get<std::string>("image");
  const double resolution = yaml.getDouble("resolution", 1e-3, 10.0);
  const std::vector<double> origin = yaml.getDoubles("origin");
  const double occupied = yaml.getDouble("occupied_thresh", 0.0, 1.0);
  const double free = yaml.getDouble("free_thresh", 0.0, 1.0);
  yaml.get<std::string>("mode");
  yaml.get<int>("negate");
  yaml.finish();
  ASSERT_EQ(origin.size(), 3u);
  const grid::Image reference = grid::readPng(test::sourceDir() + "/tests/data/" + image_name);
  ASSERT_EQ(reference.channels, 1);

  LogMapOptions options;
  options.grid.resolution = resolution;
  options.max_scans = 100;
  const LogMap map = mapFromLog(path, options);
  ASSERT_EQ(map.scans_inserted, 100u);

  // Compare every reference pixel with the cell of the new map under its centre, and count
  // the new map's known cells that fall outside the reference image.
  std::size_t known = 0, differing = 0, new_known_inside = 0;
  for (int row = 0; row < reference.height; ++row)
    for (int col = 0; col < reference.width; ++col) {
      const std::uint8_t pixel = *reference.at(col, row);
      const double x = origin[0] + (col + 0.5) * resolution;
      const double y = origin[1] + (reference.height - 1 - row + 0.5) * resolution;
      const Eigen::Vector2i c = map.grid.frame().cellOf({x, y});
      const grid::CellState state = map.grid.stateAt(c.x(), c.y(), occupied, free);
      const std::uint8_t expected = state == grid::CellState::kOccupied ? 0
                                    : state == grid::CellState::kFree   ? 254
                                                                        : 205;
      new_known_inside += expected != 205;
      if (pixel == 205 && expected == 205) continue;
      ++known;
      differing += pixel != expected;
    }
  const auto counts = map.grid.countStates();
  const std::size_t new_known = counts[1] + counts[2];
  const std::size_t outside = new_known - std::min(new_known, new_known_inside);
  const double fraction = static_cast<double>(differing + outside) / static_cast<double>(known);
  std::cout << "intel first 100 scans: " << known << " known cells, " << differing << " differ, "
            << outside << " known outside the crop: " << 100.0 * fraction << " %\n";
  EXPECT_GT(known, 50000u);  // the comparison covers a real map
  EXPECT_LT(fraction, 0.01);
}

}  // namespace
}  // namespace storey::io
