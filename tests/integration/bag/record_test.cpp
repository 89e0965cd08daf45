// `storey record` as a separate process, recording messages published over DDS here.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/FluidPressurePubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/bag/bag_reader.h"
#include "storey/runtime/bag_recorder.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_bag.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "test_support.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::runtime {
namespace {

constexpr int kDomain = 147;  // distinct from every other DDS test
constexpr int kDiscoveryDomain = 148;
constexpr int kTfStaticDomain = 50;
constexpr int kOfferedQosDomain = 51;
constexpr int kOfferedQosMcapDomain = 96;

ContextOptions onDomain(int domain) {
  ContextOptions options;
  options.domain_id = domain;
  return options;
}

pid_t spawn(const std::vector<std::string>& argv) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> args;
    args.reserve(argv.size() + 1);
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  return pid;
}

// Exit status, or -1 after the timeout (the child is then killed).
int waitFor(pid_t pid, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (std::chrono::steady_clock::now() < end) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

TEST(Record, RecordsMessagesPublishedOverDds) {
  const std::string output = test::makeTempDir("record") + "/rec";
  constexpr int kEach = 4;
  const pid_t pid =
      spawn({STOREY_COMMAND, "record", "--topics", "/rob/scan,/rob/pressure,/rob/odom", "--output",
             output, "--count", std::to_string(3 * kEach), "--duration", "30", "--domain",
             std::to_string(kDomain)});
  ASSERT_GT(pid, 0);
  {
    ContextOptions options;
    options.domain_id = kDomain;
    Context context(options);
    Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType> scans(
        context, "/rob/scan", TopicKind::kSensor);
    Publisher<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType> pressures(
        context, "/rob/pressure", TopicKind::kSensor);
    Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odoms(
        context, "/rob/odom", TopicKind::kSensor);
    ASSERT_TRUE(scans.waitForSubscribers(1, 20.0)) << "storey record did not subscribe";
    ASSERT_TRUE(pressures.waitForSubscribers(1, 5.0));
    ASSERT_TRUE(odoms.waitForSubscribers(1, 5.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // both sides matched
    for (int i = 0; i < kEach; ++i) {
      sensor::LaserScan scan;
      scan.stamp = 10.0 + i;
      scan.angle_min = -1.0;
      scan.angle_increment = 0.01;
      scan.range_max = 20.0;
      scan.ranges.assign(50, 1.0f + i);
      EXPECT_TRUE(scans.publish(toMessage(scan, "rob/laser")));
      EXPECT_TRUE(pressures.publish(toMessage(sensor::PressureSample{10.0 + i, 1000.0 + i, 0.0})));
      sensor::OdometrySample odom;
      odom.stamp = 10.0 + i;
      odom.pose = geometry::Pose2(i, 0.0, 0.0);
      EXPECT_TRUE(odoms.publish(toMessage(odom)));
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
    ASSERT_EQ(waitFor(pid, 30.0), 0) << "storey record failed or did not stop";
  }

  bag::BagReader bag(output);
  EXPECT_EQ(bag.messageCount(), 3u * kEach);
  ASSERT_EQ(bag.topics().size(), 3u);
  EXPECT_EQ(bag.topics()[0].type, "sensor_msgs/msg/LaserScan");
  SensorBagReader reader(output);
  std::vector<double> scan_stamps, pressures, odom_x;
  SensorRecord record;
  while (reader.next(record)) {
    EXPECT_EQ(record.robot, "rob");
    if (const auto* scan = std::get_if<sensor::LaserScan>(&record.data)) {
      scan_stamps.push_back(scan->stamp);
      ASSERT_EQ(scan->ranges.size(), 50u);
      EXPECT_EQ(scan->ranges[7], static_cast<float>(scan->stamp - 9.0));
    } else if (const auto* p = std::get_if<sensor::PressureSample>(&record.data)) {
      pressures.push_back(p->pascal);
    } else if (const auto* o = std::get_if<sensor::OdometrySample>(&record.data)) {
      odom_x.push_back(o->pose.x());
    }
  }
  EXPECT_EQ(scan_stamps, (std::vector<double>{10, 11, 12, 13}));
  EXPECT_EQ(pressures, (std::vector<double>{1000, 1001, 1002, 1003}));
  EXPECT_EQ(odom_x, (std::vector<double>{0, 1, 2, 3}));
  EXPECT_EQ(reader.stats().out_of_order, 0u);
}

// The offered QoS profiles (rosbag2's YAML list) of `topic` in a bag's metadata.yaml.
YAML::Node offeredQos(const std::string& bag_folder, const std::string& topic) {
  const auto metadata = bag::readMetadataFile(bag_folder + "/metadata.yaml");
  for (const bag::TopicWithCount& t : metadata.topics_with_message_count) {
    if (t.topic.name == topic) return YAML::Load(t.topic.offered_qos_profiles);
  }
  ADD_FAILURE() << "no topic " << topic << " in " << bag_folder;
  return {};
}

// A static transform published (transient local, as tf2's static broadcaster does) before
// the recording starts is recorded: ros2 bag record subscribes to tf_static that way.
TEST(Record, RecordsATfStaticPublishedBeforeTheRecordingStarts) {
  const std::string output = test::makeTempDir("record") + "/tf_static";
  Context context(onDomain(kTfStaticDomain));
  Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_static(
      context, "/tf_static", TopicKind::kGraph);
  tf2_msgs::msg::TFMessage tf;
  tf.transforms().push_back(toTransform(geometry::Pose2(0.2, 0.0, 0.0), 5.0, "base_link", "laser"));
  ASSERT_TRUE(tf_static.publish(tf));
  // Stops at the one message; without it, after the duration.
  const pid_t pid =
      spawn({STOREY_COMMAND, "record", "--topics", "tf_static", "--output", output, "--count", "1",
             "--duration", "3", "--domain", std::to_string(kTfStaticDomain)});
  ASSERT_GT(pid, 0);
  ASSERT_EQ(waitFor(pid, 30.0), 0) << "storey record failed";
  bag::BagReader bag(output);
  ASSERT_EQ(bag.messageCount(), 1u);
  bag::BagMessage message;
  ASSERT_TRUE(bag.next(message));
  const auto recorded = deserializeCdr<tf2_msgs::msg::TFMessage>(message.data);
  ASSERT_EQ(recorded.transforms().size(), 1u);
  EXPECT_EQ(recorded.transforms()[0].header().frame_id(), "base_link");
  EXPECT_EQ(recorded.transforms()[0].child_frame_id(), "laser");
  // Offered as a replay must publish it: reliable (1), transient local (1).
  const YAML::Node qos = offeredQos(output, "/tf_static");
  ASSERT_EQ(qos.size(), 1u);
  EXPECT_EQ(qos[0]["reliability"].as<int>(), 1);
  EXPECT_EQ(qos[0]["durability"].as<int>(), 1);
}

// The metadata holds the QoS the publishers offer, not the recorder's own: a reliable,
// transient-local odometry writer and a best-effort, volatile scan writer.
void recordsTheQosThePublishersOffer(const std::string& storage, int domain) {
  const std::string output = test::makeTempDir("record") + "/offered";
  const ContextOptions options = onDomain(domain);
  const pid_t pid = spawn({STOREY_COMMAND, "record", "--topics", "/rob4/odom,/rob4/scan",
                           "--output", output, "--count", "4", "--duration", "30", "--domain",
                           std::to_string(domain), "--storage", storage});
  ASSERT_GT(pid, 0);
  {
    Context context(options);
    Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odoms(
        context, "/rob4/odom", TopicKind::kGraph);
    Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType> scans(
        context, "/rob4/scan", TopicKind::kSensor);
    ASSERT_TRUE(odoms.waitForSubscribers(1, 20.0)) << "storey record did not subscribe";
    ASSERT_TRUE(scans.waitForSubscribers(1, 5.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // both sides matched
    for (int i = 0; i < 2; ++i) {
      sensor::OdometrySample odom;
      odom.stamp = 1.0 + i;
      EXPECT_TRUE(odoms.publish(toMessage(odom)));
      sensor::LaserScan scan;
      scan.stamp = 1.0 + i;
      scan.angle_increment = 0.1;
      scan.range_max = 10.0;
      scan.ranges.assign(5, 1.0f);
      EXPECT_TRUE(scans.publish(toMessage(scan, "rob4/laser")));
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
    ASSERT_EQ(waitFor(pid, 30.0), 0) << "storey record failed or did not stop";
  }
  const YAML::Node odom_qos = offeredQos(output, "/rob4/odom");
  ASSERT_EQ(odom_qos.size(), 1u);
  EXPECT_EQ(odom_qos[0]["reliability"].as<int>(), 1);  // reliable
  EXPECT_EQ(odom_qos[0]["durability"].as<int>(), 1);   // transient local
  const YAML::Node scan_qos = offeredQos(output, "/rob4/scan");
  ASSERT_EQ(scan_qos.size(), 1u);
  EXPECT_EQ(scan_qos[0]["reliability"].as<int>(), 2);  // best effort
  EXPECT_EQ(scan_qos[0]["durability"].as<int>(), 2);   // volatile
  // The database's topics table (MCAP: the channel records) says the same.
  bag::BagReader bag(output);
  EXPECT_EQ(bag.storage(), storage);
  for (const bag::TopicInfo& topic : bag.topics()) {
    EXPECT_EQ(YAML::Load(topic.offered_qos_profiles)[0]["reliability"].as<int>(),
              topic.name == "/rob4/odom" ? 1 : 2)
        << topic.name;
  }
}

TEST(Record, RecordsTheQosThePublishersOffer) {
  recordsTheQosThePublishersOffer("sqlite3", kOfferedQosDomain);
}

// MCAP keeps a channel as its first message found it: the publisher is known by then.
TEST(Record, RecordsTheQosThePublishersOfferInMcap) {
  recordsTheQosThePublishersOffer("mcap", kOfferedQosMcapDomain);
}

TEST(Record, ParsesTopicListsAndInfersSensorTypes) {
  const auto topics = parseRecordTopics("/a/scan,b/odom,/c:storey_msgs/msg/FloorEvent,/d,/e/imu");
  ASSERT_EQ(topics.size(), 5u);
  EXPECT_EQ(topics[0].type, "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(topics[1].name, "/b/odom");
  EXPECT_EQ(topics[1].type, "nav_msgs/msg/Odometry");
  EXPECT_EQ(topics[2].type, "storey_msgs/msg/FloorEvent");
  EXPECT_EQ(topics[3].type, "");  // left to discovery
  EXPECT_EQ(topics[4].type, "sensor_msgs/msg/Imu");
  EXPECT_THROW(parseRecordTopics("/a:foo_msgs/msg/Bar"), std::invalid_argument);
  EXPECT_THROW(parseRecordTopics("/a/scan,/a/scan"), std::invalid_argument);
  EXPECT_THROW(parseRecordTopics(","), std::invalid_argument);
}

TEST(Record, TakesTheTypeOfAnUntypedTopicFromDiscovery) {
  const std::string output = test::makeTempDir("record") + "/events";
  const pid_t pid =
      spawn({STOREY_COMMAND, "record", "--topics", "/rob2/floor_events", "--output", output,
             "--count", "3", "--duration", "30", "--domain", std::to_string(kDiscoveryDomain)});
  ASSERT_GT(pid, 0);
  {
    ContextOptions options;
    options.domain_id = kDiscoveryDomain;
    Context context(options);
    Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType> events(
        context, "/rob2/floor_events", TopicKind::kGraph);
    ASSERT_TRUE(events.waitForSubscribers(1, 20.0)) << "storey record did not subscribe";
    for (int i = 0; i < 3; ++i) {
      storey_msgs::msg::FloorEvent event;
      event.robot("rob2");
      event.floor_id(i + 1);
      event.floor_height(3.0 * (i + 1));
      EXPECT_TRUE(events.publish(event));
    }
    ASSERT_EQ(waitFor(pid, 30.0), 0) << "storey record failed or did not stop";
  }
  bag::BagReader bag(output);
  ASSERT_EQ(bag.topics().size(), 1u);
  EXPECT_EQ(bag.topics()[0].type, "storey_msgs/msg/FloorEvent");
  bag::BagMessage message;
  std::vector<int> floors;
  while (bag.next(message)) {
    const auto event = deserializeCdr<storey_msgs::msg::FloorEvent>(message.data);
    EXPECT_EQ(event.robot(), "rob2");
    floors.push_back(event.floor_id());
  }
  EXPECT_EQ(floors, (std::vector<int>{1, 2, 3}));
}

TEST(Record, SigintStopsTheRecordingAndClosesTheBag) {
  const std::string output = test::makeTempDir("record") + "/stopped";
  const pid_t pid = spawn({STOREY_COMMAND, "record", "--topics", "/rob3/pressure", "--output",
                           output, "--domain", std::to_string(kDiscoveryDomain)});
  ASSERT_GT(pid, 0);
  {
    ContextOptions options;
    options.domain_id = kDiscoveryDomain;
    Context context(options);
    Publisher<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType> pressures(
        context, "/rob3/pressure", TopicKind::kSensor);
    ASSERT_TRUE(pressures.waitForSubscribers(1, 20.0)) << "storey record did not subscribe";
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    for (int i = 0; i < 5; ++i) {
      EXPECT_TRUE(pressures.publish(toMessage(sensor::PressureSample{1.0 + i, 900.0 + i, 0.0})));
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(pid, SIGINT);
    ASSERT_EQ(waitFor(pid, 20.0), 0) << "storey record did not stop cleanly on SIGINT";
  }
  EXPECT_TRUE(std::filesystem::exists(output + "/metadata.yaml"));
  bag::BagReader bag(output);
  ASSERT_TRUE(bag.metadata().has_value());
  EXPECT_EQ(bag.metadata()->message_count, 5u);
  EXPECT_EQ(bag.messageCount(), 5u);
}

TEST(Record, RejectsUnknownTopicTypes) {
  const std::string output = test::makeTempDir("record") + "/bad";
  const pid_t pid = spawn({STOREY_COMMAND, "record", "--topics", "/x:foo_msgs/msg/Bar", "--output",
                           output, "--duration", "1", "--domain", std::to_string(kDomain)});
  EXPECT_EQ(waitFor(pid, 20.0), 2);  // a usage error
  // No publisher tells the type of an untyped topic: a usage error after the timeout.
  const pid_t lonely =
      spawn({STOREY_COMMAND, "record", "--topics", "/nobody/here", "--output", output + "2",
             "--discovery-timeout", "0.5", "--domain", std::to_string(kDomain)});
  EXPECT_EQ(waitFor(lonely, 20.0), 2);
}

}  // namespace
}  // namespace storey::runtime
