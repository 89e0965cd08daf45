// storey convert: a CARMEN log into a rosbag2 bag, read back with SensorBagReader.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "storey/io/carmen.h"
#include "storey/runtime/sensor_bag.h"
#include "test_support.h"

namespace storey::io {
namespace {

// Runs the storey command; returns its exit status, with stderr in *err.
int runStorey(const std::string& arguments, std::string* err = nullptr) {
  const std::string err_path = test::makeTempDir("storey_convert") + "/stderr.txt";
  const int status = std::system(
      (std::string(STOREY_COMMAND) + " " + arguments + " >/dev/null 2>" + err_path).c_str());
  if (err) {
    std::ifstream in(err_path);
    std::stringstream text;
    text << in.rdbuf();
    *err = text.str();
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

CarmenLaser laserAt(int k) {
  CarmenLaser laser;
  for (int i = 0; i < 180; ++i)
    laser.scan.ranges.push_back(1.0f + 0.01f * static_cast<float>(i + k));
  laser.scan.ranges[7] = std::numeric_limits<float>::quiet_NaN();
  laser.laser_pose = geometry::Pose2(k, 0.5 * k, 0.1 * k);
  laser.odom_pose = geometry::Pose2(k + 0.2, 0.5 * k, 0.1 * k);
  laser.scan.stamp = 100.0 + k;
  return laser;
}

std::string writeLog() {
  const std::string path = test::makeTempDir("storey_convert") + "/in.log";
  CarmenWriter writer(path);
  writer.param("robot_frontlaser_offset", "0.1");
  for (int k = 0; k < 5; ++k) {
    sensor::OdometrySample odom;
    odom.stamp = k == 2 ? 0.0 : 99.5 + k;  // one zero stamp, as in the shared logs
    odom.pose = geometry::Pose2(k, 0, 0);
    writer.odometry(odom);
    writer.flaser(laserAt(k));
  }
  writer.close();
  return path;
}

TEST(StoreyConvert, ScansAndTheirOdometryRoundTrip) {
  const std::string log = writeLog();
  const std::string bag = test::makeTempDir("storey_convert") + "/bag";
  std::string err;
  ASSERT_EQ(runStorey("convert " + log + " " + bag + " --robot r1", &err), 0) << err;
  runtime::SensorBagReader reader(bag);
  EXPECT_EQ(reader.robots(), std::vector<std::string>{"r1"});
  runtime::SensorRecord record;
  int scans = 0, odoms = 0;
  while (reader.next(record)) {
    if (const auto* scan = std::get_if<sensor::LaserScan>(&record.data)) {
      const CarmenLaser expected = laserAt(scans);
      EXPECT_EQ(record.topic, "/r1/scan");
      EXPECT_DOUBLE_EQ(scan->stamp, expected.scan.stamp);
      ASSERT_EQ(scan->ranges.size(), 180u);
      EXPECT_TRUE(std::isnan(scan->ranges[7]));
      EXPECT_EQ(scan->ranges[8], expected.scan.ranges[8]);
      EXPECT_NEAR(scan->angle_min, -M_PI / 2, 1e-6);
      EXPECT_NEAR(scan->angle_increment, M_PI / 180, 1e-6);
      EXPECT_NEAR(scan->sensor_offset.x(), 0.1, 1e-9);  // from PARAM, via /tf_static
      ++scans;
    } else if (const auto* odom = std::get_if<sensor::OdometrySample>(&record.data)) {
      const CarmenLaser expected = laserAt(odoms);
      EXPECT_EQ(record.topic, "/r1/odom");
      EXPECT_DOUBLE_EQ(odom->stamp, expected.scan.stamp);
      EXPECT_NEAR(odom->pose.x(), expected.odom_pose.x(), 1e-9);
      EXPECT_NEAR(odom->pose.theta(), expected.odom_pose.theta(), 1e-9);
      ++odoms;
    }
  }
  EXPECT_EQ(scans, 5);
  EXPECT_EQ(odoms, 5);
}

TEST(StoreyConvert, OdometryLinesDropZeroStamps) {
  const std::string bag = test::makeTempDir("storey_convert") + "/bag";
  ASSERT_EQ(runStorey("convert " + writeLog() + " " + bag + " --odom lines"), 0);
  runtime::SensorBagReader reader(bag);
  runtime::SensorRecord record;
  std::vector<double> stamps;
  while (reader.next(record))
    if (const auto* odom = std::get_if<sensor::OdometrySample>(&record.data))
      stamps.push_back(odom->stamp);
  EXPECT_EQ(stamps, (std::vector<double>{99.5, 100.5, 102.5, 103.5}));
}

TEST(StoreyConvert, RestampAndOffset) {
  const std::string bag = test::makeTempDir("storey_convert") + "/bag";
  ASSERT_EQ(runStorey("convert " + writeLog() + " " + bag + " --restamp 4 --stamp-offset 10"), 0);
  runtime::SensorBagReader reader(bag);
  runtime::SensorRecord record;
  std::vector<double> scan_stamps, odom_stamps;
  while (reader.next(record)) {
    if (const auto* scan = std::get_if<sensor::LaserScan>(&record.data))
      scan_stamps.push_back(scan->stamp);
    if (const auto* odom = std::get_if<sensor::OdometrySample>(&record.data))
      odom_stamps.push_back(odom->stamp);
  }
  EXPECT_EQ(scan_stamps, (std::vector<double>{10.0, 10.25, 10.5, 10.75, 11.0}));
  EXPECT_EQ(odom_stamps, scan_stamps);
  // A stamp that ends up negative is refused with its line.
  std::string err;
  EXPECT_EQ(runStorey("convert " + writeLog() + " " + bag + "2 --stamp-offset -100.5", &err), 1);
  EXPECT_NE(err.find("in.log:3: stamp -0.5 s is negative"), std::string::npos) << err;
  EXPECT_EQ(runStorey("convert " + writeLog() + " " + bag + "3 --restamp 4 --odom lines", &err), 2);
}

TEST(StoreyConvert, BadInputFailsWithTheFileAndLine) {
  const std::string dir = test::makeTempDir("storey_convert");
  {
    std::ofstream out(dir + "/bad.log");
    out << "ODOM 0 0 0 0 0 0 1\nFLASER 3 1 2\n";
  }
  std::string err;
  EXPECT_EQ(runStorey("convert " + dir + "/bad.log " + dir + "/bag", &err), 1);
  EXPECT_NE(err.find(dir + "/bad.log:2:"), std::string::npos) << err;
  EXPECT_EQ(runStorey("convert " + dir + "/bad.log " + dir + "/bag2 --lenient"), 0);
  EXPECT_EQ(runStorey("convert " + dir + "/bad.log " + dir + "/bag3 --odom sometimes", &err), 2);
  EXPECT_NE(err.find("--odom must be scans or lines"), std::string::npos) << err;
  EXPECT_EQ(runStorey("convert " + dir + "/missing.log " + dir + "/bag4", &err), 1);
  EXPECT_NE(err.find("missing.log"), std::string::npos) << err;
}

TEST(StoreyConvert, IntelLogBecomesABag) {
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  const std::string bag = test::makeTempDir("storey_convert") + "/intel";
  ASSERT_EQ(runStorey("convert " + path + " " + bag), 0);
  runtime::SensorBagReader reader(bag);
  runtime::SensorRecord record;
  std::size_t scans = 0;
  while (reader.next(record)) scans += std::holds_alternative<sensor::LaserScan>(record.data);
  EXPECT_EQ(scans, 910u);
}

}  // namespace
}  // namespace storey::io
