// `storey replay`'s replayer over DDS on loopback: what a subscriber that joins late gets.
#include "storey/tools/replay.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "storey/runtime/context.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/subscription.h"
#include "test_support.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::tools {
namespace {

constexpr int kDomain = 52;  // distinct from every other DDS test

// tf2's static listener is reliable and transient local and joins whenever it starts: the
// replayed mounting must still reach it after it was published.
TEST(Replay, TfStaticReachesAReaderThatJoinsAfterwards) {
  const std::string folder = test::makeTempDir("replay") + "/bag";
  {
    runtime::SensorBagWriter writer(folder);
    sensor::LaserScan scan;
    scan.stamp = 1.0;
    scan.angle_increment = 0.1;
    scan.range_max = 10.0;
    scan.ranges.assign(5, 2.0f);
    scan.sensor_offset = geometry::Pose2(0.25, 0.0, 0.0);
    writer.write("rep", scan);
  }
  runtime::ContextOptions options;
  options.domain_id = kDomain;
  options.participant_name = "replay_test_replay";
  runtime::Context replay_context(options);
  ReplayOptions replay_options;
  replay_options.settle_seconds = 0.0;
  replay_options.ack_seconds = 0.0;
  SensorReplayer replayer(replay_context, replay_options);
  auto source = openSensorSource(folder, replay_options);
  const ReplaySummary summary = replayer.replay(*source);
  ASSERT_EQ(summary.total, 1u);

  // Another participant, as tf2's listener would be, joining after the replay published.
  options.participant_name = "replay_test_listener";
  runtime::Context listener_context(options);
  std::atomic<int> received{0};
  std::atomic<double> offset_x{0.0};
  runtime::Subscription<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_static(
      listener_context, "tf_static", runtime::TopicKind::kGraph,
      [&](const tf2_msgs::msg::TFMessage& m) {
        if (!m.transforms().empty()) offset_x = m.transforms()[0].transform().translation().x();
        ++received;
      });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(4);
  while (received == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_EQ(received.load(), 1);
  EXPECT_DOUBLE_EQ(offset_x.load(), 0.25);
}

}  // namespace
}  // namespace storey::tools
