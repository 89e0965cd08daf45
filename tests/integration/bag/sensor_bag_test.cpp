#include "storey/runtime/sensor_bag.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <random>

#include "geometry_msgs/msg/PoseStamped.h"
#include "storey/bag/bag_error.h"
#include "storey/bag/bag_reader.h"
#include "storey/runtime/sensor_conversions.h"
#include "test_support.h"
#include "tf2_msgs/msg/TFMessage.h"

namespace storey::runtime {
namespace {

sensor::LaserScan makeScan(double stamp, std::mt19937& rng, const geometry::Pose2& offset) {
  sensor::LaserScan scan;
  scan.stamp = stamp;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 180;
  scan.range_min = 0.1;
  scan.range_max = 30.0;
  std::uniform_real_distribution<float> range(0.2f, 29.0f);
  for (int i = 0; i < 181; ++i) scan.ranges.push_back(range(rng));
  scan.ranges[5] = std::numeric_limits<float>::infinity();
  scan.sensor_offset = offset;
  return scan;
}

TEST(SensorConversions, TimeConversionsAreExactInNanoseconds) {
  for (std::int64_t ns :
       {std::int64_t{0}, std::int64_t{1}, std::int64_t{999'999'999},
        std::int64_t{1'700'000'000'123'456'789}, std::int64_t{-1}, std::int64_t{-1'500'000'000}}) {
    EXPECT_EQ(timeMessageToNanoseconds(nanosecondsToTimeMessage(ns)), ns);
    EXPECT_LT(nanosecondsToTimeMessage(ns).nanosec(), 1'000'000'000u);
  }
  EXPECT_EQ(stampToNanoseconds(12.5), 12'500'000'000);
  EXPECT_EQ(stampToNanoseconds(-0.25), -250'000'000);
  const double stamp = 1'700'000'000.123456;
  EXPECT_NEAR(nanosecondsToStamp(stampToNanoseconds(stamp)), stamp, 1e-6);
  EXPECT_NEAR(fromTimeMessage(toTimeMessage(stamp)), stamp, 1e-6);
  EXPECT_THROW(stampToNanoseconds(std::nan("")), std::invalid_argument);
  EXPECT_THROW(stampToNanoseconds(1e300), std::invalid_argument);
}

TEST(SensorConversions, YawSurvivesTheQuaternion) {
  for (double yaw = -3.14; yaw < 3.14; yaw += 0.1) {
    EXPECT_NEAR(quaternionToYaw(yawToQuaternion(yaw)), yaw, 1e-12);
  }
  EXPECT_NEAR(std::abs(quaternionToYaw(yawToQuaternion(M_PI))), M_PI, 1e-12);
}

TEST(SensorConversions, LaserScanRoundTrip) {
  std::mt19937 rng(1);
  const sensor::LaserScan scan = makeScan(100.25, rng, geometry::Pose2(0.2, 0.0, 0.1));
  const sensor_msgs::msg::LaserScan msg = toMessage(scan, "r1/laser");
  EXPECT_EQ(msg.header().frame_id(), "r1/laser");
  EXPECT_EQ(msg.header().stamp().sec(), 100);
  EXPECT_EQ(msg.header().stamp().nanosec(), 250'000'000u);
  EXPECT_NEAR(msg.angle_max(), M_PI / 2, 1e-6);
  const sensor::LaserScan back = fromMessage(msg, scan.sensor_offset);
  EXPECT_DOUBLE_EQ(back.stamp, scan.stamp);
  EXPECT_NEAR(back.angle_min, scan.angle_min, 1e-7);  // float precision on the wire
  EXPECT_NEAR(back.angle_increment, scan.angle_increment, 1e-9);
  EXPECT_FLOAT_EQ(back.range_max, 30.0f);
  EXPECT_EQ(back.ranges, scan.ranges);
  EXPECT_EQ(back.sensor_offset.x(), 0.2);
  EXPECT_EQ(back.validate(), "");
}

TEST(SensorConversions, OdometryPressureImuRoundTrip) {
  sensor::OdometrySample odom;
  odom.stamp = 3.5;
  odom.pose = geometry::Pose2(1.5, -2.0, 2.9);
  odom.linear_velocity = 0.4;
  odom.angular_velocity = -0.2;
  odom.z = 3.1;
  const nav_msgs::msg::Odometry om = toMessage(odom, "r/odom", "r/base_link");
  EXPECT_EQ(om.child_frame_id(), "r/base_link");
  const sensor::OdometrySample ob = fromMessage(om);
  EXPECT_DOUBLE_EQ(ob.stamp, 3.5);
  EXPECT_DOUBLE_EQ(ob.pose.x(), 1.5);
  EXPECT_DOUBLE_EQ(ob.pose.y(), -2.0);
  EXPECT_NEAR(ob.pose.theta(), 2.9, 1e-12);
  EXPECT_DOUBLE_EQ(ob.z, 3.1);
  EXPECT_DOUBLE_EQ(ob.linear_velocity, 0.4);
  EXPECT_DOUBLE_EQ(ob.angular_velocity, -0.2);

  const sensor::PressureSample pb =
      fromMessage(toMessage(sensor::PressureSample{7.0, 101325.5, 4.0}));
  EXPECT_DOUBLE_EQ(pb.stamp, 7.0);
  EXPECT_DOUBLE_EQ(pb.pascal, 101325.5);
  EXPECT_DOUBLE_EQ(pb.variance, 4.0);

  sensor::ImuSample imu;
  imu.stamp = 8.0;
  imu.linear_acceleration = {0.1, 0.2, 9.81};
  imu.angular_velocity = {0.01, -0.02, 0.3};
  const sensor_msgs::msg::Imu im = toMessage(imu);
  EXPECT_EQ(im.orientation_covariance()[0], -1.0);  // orientation unknown
  const sensor::ImuSample ib = fromMessage(im);
  EXPECT_EQ(ib.linear_acceleration, imu.linear_acceleration);
  EXPECT_EQ(ib.angular_velocity, imu.angular_velocity);
}

TEST(BagCdr, SerializesWithTheEncapsulationHeaderAndRejectsTruncatedBytes) {
  std::mt19937 rng(2);
  const auto msg = toMessage(makeScan(1.0, rng, {}), "laser");
  const std::vector<std::uint8_t> bytes = serializeCdr(msg);
  ASSERT_GE(bytes.size(), 4u + 181 * 4);
  EXPECT_EQ(bytes[0], 0x00);
  EXPECT_EQ(bytes[1], 0x01);  // CDR little endian, as ROS 2 on x86 writes
  const auto back = deserializeCdr<sensor_msgs::msg::LaserScan>(bytes);
  EXPECT_TRUE(back == msg);
  for (std::size_t cut : {std::size_t{0}, std::size_t{3}, std::size_t{30}, bytes.size() - 1}) {
    std::vector<std::uint8_t> truncated(bytes.begin(), bytes.begin() + cut);
    EXPECT_THROW(deserializeCdr<sensor_msgs::msg::LaserScan>(truncated, "scan"), CdrError) << cut;
  }
  // A huge sequence length must not allocate or crash.
  std::vector<std::uint8_t> absurd = bytes;
  // encapsulation, stamp, frame_id length + "laser\0" + padding, seven floats.
  const std::size_t ranges_length_at = 4 + 8 + 4 + 6 + 2 + 7 * 4;
  ASSERT_EQ(absurd[ranges_length_at], 181u);
  absurd[ranges_length_at + 3] = 0x7f;
  EXPECT_THROW(deserializeCdr<sensor_msgs::msg::LaserScan>(absurd, "scan"), CdrError);
}

TEST(BagCdr, TypeNames) {
  EXPECT_EQ(rosTypeName("sensor_msgs::msg::dds_::LaserScan_"), "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(ddsTypeName("sensor_msgs/msg/LaserScan"), "sensor_msgs::msg::dds_::LaserScan_");
  EXPECT_EQ(rosTypeName(ddsTypeName("storey_msgs/msg/FloorEvent")), "storey_msgs/msg/FloorEvent");
}

TEST(SensorBag, WriterThenReaderGivesTheSameSamplesInTimeOrder) {
  const std::string folder = test::makeTempDir("sensor_bag") + "/run";
  std::mt19937 rng(5);
  struct Expected {
    std::string robot;
    SensorData data;
  };
  std::vector<Expected> expected;
  {
    SensorBagWriter writer(folder);
    for (int i = 0; i < 50; ++i) {
      const double t = 1000.0 + 0.1 * i;
      for (const std::string robot : {"alpha", "beta"}) {
        const geometry::Pose2 offset(robot == "alpha" ? 0.25 : -0.1, 0.0, 0.0);
        sensor::OdometrySample odom{t, geometry::Pose2(0.1 * i, 0.0, 0.01 * i), 0.5, 0.1, 0.0};
        sensor::PressureSample pressure{t + 0.01, 101000.0 + i, 1.0};
        sensor::ImuSample imu;
        imu.stamp = t + 0.02;
        imu.linear_acceleration = {0.0, 0.0, 9.8 + 0.001 * i};
        sensor::LaserScan scan = makeScan(t + 0.03, rng, offset);
        writer.write(robot, odom);
        writer.write(robot, pressure);
        writer.write(robot, imu);
        writer.write(robot, scan);
        expected.push_back({robot, odom});
        expected.push_back({robot, pressure});
        expected.push_back({robot, imu});
        expected.push_back({robot, scan});
      }
      // A topic of another type is skipped by the reader (and counted).
      geometry_msgs::msg::PoseStamped truth;
      truth.pose().position().x(i);
      writer.writeMessage("/alpha/ground_truth", "geometry_msgs/msg/PoseStamped", t, truth);
    }
    EXPECT_THROW(writer.write("bad name!", sensor::PressureSample{}), std::invalid_argument);
    EXPECT_THROW(writer.write("alpha", sensor::PressureSample{std::nan(""), 1.0, 0.0}),
                 std::invalid_argument);
  }
  auto stampOf = [](const SensorData& d) {
    return std::visit([](const auto& s) { return s.stamp; }, d);
  };
  std::stable_sort(expected.begin(), expected.end(), [&](const Expected& a, const Expected& b) {
    return stampToNanoseconds(stampOf(a.data)) < stampToNanoseconds(stampOf(b.data));
  });

  SensorBagReader reader(folder);
  EXPECT_EQ(reader.robots(), (std::vector<std::string>{"alpha", "beta"}));
  SensorRecord record;
  std::size_t i = 0;
  for (; reader.next(record); ++i) {
    ASSERT_LT(i, expected.size());
    const Expected& e = expected[i];
    EXPECT_EQ(record.robot, e.robot) << i;
    ASSERT_EQ(record.data.index(), e.data.index()) << i;
    EXPECT_NEAR(record.stamp, stampOf(e.data), 1e-9) << i;
    EXPECT_EQ(record.bag_stamp_ns, stampToNanoseconds(stampOf(e.data)));
    if (const auto* scan = std::get_if<sensor::LaserScan>(&record.data)) {
      const auto& want = std::get<sensor::LaserScan>(e.data);
      EXPECT_EQ(scan->ranges, want.ranges);
      EXPECT_NEAR(scan->angle_min, want.angle_min, 1e-7);
      EXPECT_NEAR(scan->angle_increment, want.angle_increment, 1e-9);
      EXPECT_NEAR(scan->sensor_offset.x(), want.sensor_offset.x(), 1e-12) << "from /tf_static";
      EXPECT_EQ(record.topic, "/" + e.robot + "/scan");
    } else if (const auto* odom = std::get_if<sensor::OdometrySample>(&record.data)) {
      const auto& want = std::get<sensor::OdometrySample>(e.data);
      EXPECT_NEAR(odom->pose.x(), want.pose.x(), 1e-12);
      EXPECT_NEAR(odom->pose.theta(), want.pose.theta(), 1e-12);
      EXPECT_EQ(odom->linear_velocity, want.linear_velocity);
    } else if (const auto* p = std::get_if<sensor::PressureSample>(&record.data)) {
      EXPECT_EQ(p->pascal, std::get<sensor::PressureSample>(e.data).pascal);
    } else if (const auto* imu = std::get_if<sensor::ImuSample>(&record.data)) {
      EXPECT_EQ(imu->linear_acceleration, std::get<sensor::ImuSample>(e.data).linear_acceleration);
    }
  }
  EXPECT_EQ(i, expected.size());
  EXPECT_EQ(reader.stats().yielded, expected.size());
  EXPECT_EQ(reader.stats().skipped, 50u);
  EXPECT_EQ(reader.stats().skipped_topics, (std::vector<std::string>{"/alpha/ground_truth"}));
  EXPECT_EQ(reader.stats().out_of_order, 0u);
  EXPECT_EQ(reader.stats().malformed, 0u);
}

TEST(SensorBag, OutOfOrderAndMalformedMessagesAreCountedNotFatal) {
  const std::string folder = test::makeTempDir("sensor_bag") + "/odd";
  {
    bag::BagWriter writer(folder);
    writer.createTopic({"/r/odom", kOdometryType, "cdr", ""});
    writer.createTopic({"/r/scan", kLaserScanType, "cdr", ""});
    // Header stamps 1, 3, 2 recorded at increasing bag times: one out of order.
    int k = 0;
    for (double t : {1.0, 3.0, 2.0}) {
      sensor::OdometrySample odom;
      odom.stamp = t;
      writer.write("/r/odom", 10 + k++, serializeCdr(toMessage(odom)));
    }
    writer.write("/r/scan", 20, {0x00, 0x01, 0x00, 0x00, 0x05});  // truncated LaserScan
  }
  SensorBagReader reader(folder);
  SensorRecord record;
  std::vector<double> stamps;
  while (reader.next(record)) stamps.push_back(record.stamp);
  EXPECT_EQ(stamps, (std::vector<double>{1.0, 3.0, 2.0}));
  EXPECT_EQ(reader.stats().out_of_order, 1u);
  EXPECT_EQ(reader.stats().malformed, 1u);
}

// tf2's static listener subscribes reliable and transient local: a bag offering
// /tf_static volatile replays (ros2 bag play) to a writer it cannot match.
TEST(SensorBag, TfStaticIsOfferedReliableAndTransientLocal) {
  const std::string folder = test::makeTempDir("sensor_bag") + "/qos";
  std::mt19937 rng(3);
  {
    SensorBagWriter writer(folder);
    writer.write("r", makeScan(1.0, rng, geometry::Pose2(0.2, 0.0, 0.0)));
    sensor::OdometrySample odom;
    odom.stamp = 1.0;
    writer.write("r", odom);
  }
  const bag::BagMetadata metadata = bag::readMetadataFile(folder + "/metadata.yaml");
  std::map<std::string, YAML::Node> qos;
  for (const bag::TopicWithCount& t : metadata.topics_with_message_count)
    qos[t.topic.name] = YAML::Load(t.topic.offered_qos_profiles);
  ASSERT_EQ(qos.count(kTfStaticTopic), 1u);
  EXPECT_EQ(qos[kTfStaticTopic][0]["reliability"].as<int>(), 1);  // reliable
  EXPECT_EQ(qos[kTfStaticTopic][0]["durability"].as<int>(), 1);   // transient local
  EXPECT_EQ(qos["/r/odom"][0]["reliability"].as<int>(), 2);       // sensors: best effort
  EXPECT_EQ(qos["/r/odom"][0]["durability"].as<int>(), 2);        // and volatile
}

// RViz and Foxglove place a robot by /tf (odom -> base_link, REP 105) and its sensors by
// /tf_static: a bag storey writes carries both, every static transform in each tf_static
// message (a late listener keeps only the last one), and reads back without skipping.
TEST(SensorBag, OdometryIsOnTfAndEveryMountingOnTfStatic) {
  const std::string folder = test::makeTempDir("sensor_bag") + "/tf";
  std::mt19937 rng(4);
  {
    SensorBagWriter writer(folder);
    writer.write("r", makeScan(1.0, rng, geometry::Pose2(0.2, 0.05, 0.1)));
    sensor::ImuSample imu;
    imu.stamp = 1.0;
    writer.write("r", imu);
    for (int k = 0; k < 3; ++k) {
      sensor::OdometrySample odom;
      odom.stamp = 1.0 + k;
      odom.pose = geometry::Pose2(0.5 * k, 0.1, 0.2 * k);
      writer.write("r", odom);
    }
  }
  bag::BagReader bag(folder);
  std::vector<tf2_msgs::msg::TFMessage> tf, tf_static;
  bag::BagMessage message;
  while (bag.next(message)) {
    const std::string& topic = bag.topics()[message.topic_index].name;
    if (topic != kTfTopic && topic != kTfStaticTopic) continue;
    tf2_msgs::msg::TFMessage m;
    deserializeCdr(message.data.data(), message.data.size(), m, kTfMessageType);
    (topic == kTfTopic ? tf : tf_static).push_back(m);
  }
  ASSERT_EQ(tf.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(tf[k].transforms().size(), 1u);
    const auto& t = tf[k].transforms()[0];
    EXPECT_EQ(t.header().frame_id(), "r/odom");
    EXPECT_EQ(t.child_frame_id(), "r/base_link");
    const geometry::Pose2 pose = fromTransform(t);
    EXPECT_NEAR(pose.x(), 0.5 * k, 1e-9);
    EXPECT_NEAR(pose.theta(), 0.2 * k, 1e-9);
  }
  ASSERT_FALSE(tf_static.empty());
  std::map<std::string, std::string> last;  // child -> parent, in the last message
  for (const auto& t : tf_static.back().transforms())
    last[t.child_frame_id()] = t.header().frame_id();
  EXPECT_EQ(last, (std::map<std::string, std::string>{{"r/imu", "r/base_link"},
                                                      {"r/laser", "r/base_link"}}));
  SensorBagReader reader(folder);
  SensorRecord record;
  while (reader.next(record)) {
  }
  EXPECT_EQ(reader.stats().skipped, 0u);
  EXPECT_TRUE(reader.stats().skipped_topics.empty());
  EXPECT_EQ(reader.robots(), (std::vector<std::string>{"r"}));
}

}  // namespace
}  // namespace storey::runtime
