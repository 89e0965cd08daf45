// A robot's topic names the ROS way: relative to its namespace or absolute, as the
// components' *_topic keys give them, and a bag read by those names.
#include "storey/runtime/sensor_topics.h"

#include <yaml-cpp/yaml.h>

#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

TEST(SensorTopics, RelativeNamesTakeTheNamespaceAndAbsoluteOnesDoNot) {
  EXPECT_EQ(robotTopic("robot1", "scan"), "/robot1/scan");
  EXPECT_EQ(robotTopic("", "scan"), "/scan");
  EXPECT_EQ(robotTopic("fleet/r2", "front/scan"), "/fleet/r2/front/scan");
  EXPECT_EQ(robotTopic("robot1", "/odometry/filtered"), "/odometry/filtered");
  EXPECT_THROW(robotTopic("robot1", "front scan"), std::invalid_argument);
  EXPECT_THROW(robotTopic("robot1", "/"), std::invalid_argument);
  EXPECT_THROW(robotTopic("robot1", ""), std::invalid_argument);
  EXPECT_THROW(robotTopic("1robot", "scan"), std::invalid_argument);

  EXPECT_EQ(robotOfTopic("/robot1/scan", "scan"), std::optional<std::string>("robot1"));
  EXPECT_EQ(robotOfTopic("/scan", "scan"), std::optional<std::string>(""));
  EXPECT_EQ(robotOfTopic("/fleet/r2/front/scan", "front/scan"),
            std::optional<std::string>("fleet/r2"));
  EXPECT_EQ(robotOfTopic("/robot1/laser_scan", "scan"), std::nullopt);  // not "/scan" at the end
  EXPECT_EQ(robotOfTopic("/front/scan", "/front/scan"), std::optional<std::string>(""));
  EXPECT_EQ(robotOfTopic("/robot1/front/scan", "/front/scan"), std::nullopt);
}

TEST(SensorTopics, KeysAreReadAndCheckedNamingTheFile) {
  const YAML::Node yaml = YAML::Load("scan_topic: /front/scan\nodom_topic: odometry/filtered\n");
  const SensorTopics topics =
      readSensorTopics(common::ConfigNode(yaml, "mapper.yaml", ""), "r1", SensorTopics{}, true);
  EXPECT_EQ(topics.scan, "/front/scan");
  EXPECT_EQ(topics.odom, "odometry/filtered");
  EXPECT_EQ(topics.imu, "imu");  // optional: the default
  EXPECT_EQ(topics.pressure, "pressure");
  try {
    readSensorTopics(common::ConfigNode(YAML::Load("imu_topic: imu data\n"), "detector.yaml", ""),
                     "r1", SensorTopics{}, true);
    FAIL() << "a topic name with a space was taken";
  } catch (const common::ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("detector.yaml"), std::string::npos) << what;
    EXPECT_NE(what.find("imu_topic"), std::string::npos) << what;
  }
}

// A bag with a single robot's plain names: read as robot "" when the names are given;
// with the shipped names, what they do not name is skipped and listed.
TEST(SensorTopics, ABagIsReadByTheNamesGiven) {
  const std::string folder = test::makeTempDir("sensor_topics") + "/bag";
  {
    SensorBagWriter writer(folder);
    sensor::LaserScan scan;
    scan.stamp = 1.0;
    scan.angle_increment = 0.1;
    scan.range_max = 10.0;
    scan.ranges.assign(5, 2.0f);
    sensor::OdometrySample odom;
    odom.stamp = 1.0;
    writer.writeMessage("/front/scan", kLaserScanType, 1.0, toMessage(scan, "laser"), false);
    writer.writeMessage("/odometry/filtered", kOdometryType, 1.0,
                        toMessage(odom, "odom", "base_link"), false);
  }
  SensorBagReader named(folder,
                        SensorTopics{"/front/scan", "/odometry/filtered", "imu", "pressure"});
  EXPECT_EQ(named.robots(), std::vector<std::string>{""});
  EXPECT_TRUE(named.sensorsOf("").scan);
  EXPECT_TRUE(named.sensorsOf("").odometry);
  SensorRecord record;
  int read = 0;
  while (named.next(record)) {
    EXPECT_EQ(record.robot, "");
    ++read;
  }
  EXPECT_EQ(read, 2);

  // The shipped names: /front/scan is robot front's scan; nobody's odometry is read.
  SensorBagReader shipped(folder);
  EXPECT_EQ(shipped.robots(), std::vector<std::string>{"front"});
  EXPECT_FALSE(shipped.sensorsOf("front").odometry);
  EXPECT_EQ(shipped.stats().skipped_topics, std::vector<std::string>{"/odometry/filtered"});
}

}  // namespace
}  // namespace storey::runtime
