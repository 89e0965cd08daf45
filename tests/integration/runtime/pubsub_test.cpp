// Typed publishers and subscriptions through one Context: delivery, QoS by topic kind,
// callbacks on the executor, and transient-local history for late subscribers.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include "sensor_msgs/msg/FluidPressure.h"
#include "sensor_msgs/msg/FluidPressurePubSubTypes.h"
#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/subscription.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

using FloorEventPub =
    Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;
using FloorEventSub =
    Subscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;
using ScanPub = Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>;
using ScanSub = Subscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>;

template <typename Pred>
bool waitFor(Pred pred, double timeout_s = 5.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

ContextOptions optionsForDomain(int domain) {
  ContextOptions options;
  options.domain_id = domain;
  return options;
}

TEST(RuntimePubSub, TopicNamesFollowRos2) {
  EXPECT_EQ(Context::ddsTopicName("scan"), "rt/scan");
  EXPECT_EQ(Context::ddsTopicName("/robot1/scan"), "rt/robot1/scan");
  EXPECT_THROW(Context::ddsTopicName(""), DdsError);
}

TEST(RuntimePubSub, TypeNamesFollowRos2) {
  sensor_msgs::msg::LaserScanPubSubType scan_type;
  EXPECT_STREQ(scan_type.getName(), "sensor_msgs::msg::dds_::LaserScan_");
  storey_msgs::msg::FloorEventPubSubType event_type;
  EXPECT_STREQ(event_type.getName(), "storey_msgs::msg::dds_::FloorEvent_");
}

TEST(RuntimePubSub, ScanArrivesIntactOnTheExecutorThread) {
  Context context(optionsForDomain(101));
  std::mutex mutex;
  std::vector<sensor_msgs::msg::LaserScan> received;
  std::atomic<bool> on_executor{true};
  ScanSub sub(context, "robot1/scan", TopicKind::kSensor, [&](const auto& scan) {
    if (!context.executor().onWorkerThread()) on_executor = false;
    std::lock_guard<std::mutex> lock(mutex);
    received.push_back(scan);
  });
  ScanPub pub(context, "robot1/scan", TopicKind::kSensor);
  ASSERT_TRUE(pub.waitForSubscribers(1, 5.0));
  sensor_msgs::msg::LaserScan scan;
  scan.header().frame_id("laser");
  scan.header().stamp().sec(12);
  scan.angle_min(-1.5f);
  scan.angle_increment(0.01f);
  for (int i = 0; i < 1080; ++i) scan.ranges().push_back(0.5f + 0.001f * i);
  ASSERT_TRUE(pub.publish(scan));
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return !received.empty();
  }));
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(received[0].header().frame_id(), "laser");
  EXPECT_EQ(received[0].header().stamp().sec(), 12);
  EXPECT_FLOAT_EQ(received[0].angle_min(), -1.5f);
  ASSERT_EQ(received[0].ranges().size(), 1080u);
  EXPECT_FLOAT_EQ(received[0].ranges()[1079], 0.5f + 0.001f * 1079);
  EXPECT_TRUE(on_executor);
}

// Within one process delivery is synchronous, so a burst published while the worker is
// held arrives in the subscription's hand-off queue before any callback runs.
TEST(RuntimePubSub, SensorSubscriberThatFallsBehindKeepsTheLastDepthScans) {
  Context context(optionsForDomain(188));
  std::vector<int> stamps;  // only touched on the worker
  ScanSub sub(context, "robot1/scan", TopicKind::kSensor,
              [&](const auto& scan) { stamps.push_back(scan.header().stamp().sec()); });
  ScanPub pub(context, "robot1/scan", TopicKind::kSensor);
  ASSERT_TRUE(pub.waitForSubscribers(1, 5.0));
  std::mutex gate;  // holds the worker; nothing between lock and unlock may return early
  gate.lock();
  context.executor().post([&] { std::lock_guard<std::mutex> wait(gate); });
  for (int i = 0; i < 50; ++i) {
    sensor_msgs::msg::LaserScan scan;
    scan.header().stamp().sec(i);
    // Sizes vary so that a reused sample must shrink and grow correctly.
    scan.ranges().assign(i % 2 == 0 ? 1080 : 3, static_cast<float>(i));
    EXPECT_TRUE(pub.publish(scan));
  }
  gate.unlock();
  context.executor().drain();
  // keep last 10 (config/dds/qos_profiles.xml): the 40 oldest gave way.
  ASSERT_EQ(stamps.size(), 10u);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(stamps[i], 40 + i);
  EXPECT_EQ(sub.receivedCount(), 10u);
  EXPECT_EQ(sub.droppedCount(), 40u);

  // Once caught up, every scan arrives, intact although its sample object is reused.
  std::vector<std::size_t> sizes;
  std::vector<float> lasts;
  ScanSub sized(context, "robot1/scan", TopicKind::kSensor, [&](const auto& scan) {
    sizes.push_back(scan.ranges().size());
    lasts.push_back(scan.ranges().empty() ? -1.f : scan.ranges().back());
  });
  ASSERT_TRUE(pub.waitForSubscribers(2, 5.0));
  for (int i = 0; i < 6; ++i) {
    sensor_msgs::msg::LaserScan scan;
    scan.ranges().assign(i % 2 == 0 ? 1080 : 3, static_cast<float>(i));
    ASSERT_TRUE(pub.publish(scan));
    context.executor().drain();
  }
  ASSERT_EQ(sizes.size(), 6u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(sizes[i], i % 2 == 0 ? 1080u : 3u);
    EXPECT_EQ(lasts[i], static_cast<float>(i));
  }
  EXPECT_EQ(sized.droppedCount(), 0u);
}

TEST(RuntimePubSub, GraphSubscriberThatFallsBehindLosesNothing) {
  Context context(optionsForDomain(189));
  std::vector<int> floors;  // only touched on the worker
  FloorEventSub sub(context, "floor_events", TopicKind::kGraph,
                    [&](const auto& e) { floors.push_back(e.floor_id()); });
  FloorEventPub pub(context, "floor_events", TopicKind::kGraph);
  ASSERT_TRUE(pub.waitForSubscribers(1, 5.0));
  std::mutex gate;  // holds the worker; nothing between lock and unlock may return early
  gate.lock();
  context.executor().post([&] { std::lock_guard<std::mutex> wait(gate); });
  for (int i = 0; i < 500; ++i) {
    storey_msgs::msg::FloorEvent event;
    event.floor_id(i);
    EXPECT_TRUE(pub.publish(event));
  }
  gate.unlock();
  context.executor().drain();
  ASSERT_EQ(floors.size(), 500u);
  for (int i = 0; i < 500; ++i) ASSERT_EQ(floors[i], i);
  EXPECT_EQ(sub.droppedCount(), 0u);
}

TEST(RuntimePubSub, InactivePublisherSendsNothing) {
  Context context(optionsForDomain(102));
  std::atomic<int> count{0};
  FloorEventSub sub(context, "floor_events", TopicKind::kGraph, [&](const auto&) { ++count; });
  FloorEventPub pub(context, "floor_events", TopicKind::kGraph, /*active=*/false);
  ASSERT_TRUE(pub.waitForSubscribers(1, 5.0));
  storey_msgs::msg::FloorEvent event;
  EXPECT_FALSE(pub.publish(event));
  EXPECT_EQ(pub.droppedInactiveCount(), 1u);
  pub.setActive(true);
  EXPECT_TRUE(pub.publish(event));
  ASSERT_TRUE(waitFor([&] { return count == 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(count, 1);
}

TEST(RuntimePubSub, LateGraphSubscriberGetsHistoryInOrder) {
  Context context(optionsForDomain(103));
  FloorEventPub pub(context, "robot1/floor_events", TopicKind::kGraph);
  for (int i = 0; i < 50; ++i) {
    storey_msgs::msg::FloorEvent event;
    event.robot("robot1");
    event.floor_id(i);
    ASSERT_TRUE(pub.publish(event));
  }
  std::mutex mutex;
  std::vector<int> floors;
  FloorEventSub sub(context, "robot1/floor_events", TopicKind::kGraph, [&](const auto& e) {
    std::lock_guard<std::mutex> lock(mutex);
    floors.push_back(e.floor_id());
  });
  ASSERT_TRUE(waitFor([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return floors.size() >= 50;
  }));
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(floors.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(floors[i], i);
}

TEST(RuntimePubSub, LateSensorSubscriberGetsNoHistory) {
  Context context(optionsForDomain(104));
  ScanPub pub(context, "robot1/scan", TopicKind::kSensor);
  ASSERT_TRUE(pub.publish(sensor_msgs::msg::LaserScan()));
  std::atomic<int> count{0};
  ScanSub sub(context, "robot1/scan", TopicKind::kSensor, [&](const auto&) { ++count; });
  ASSERT_TRUE(pub.waitForSubscribers(1, 5.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(count, 0);
}

TEST(RuntimePubSub, OneTopicNameHasOneType) {
  Context context(optionsForDomain(105));
  ScanPub pub(context, "things", TopicKind::kSensor);
  EXPECT_THROW(FloorEventPub(context, "things", TopicKind::kGraph), DdsError);
}

TEST(RuntimeExecutor, TimersTickAndStopOnCancel) {
  Executor executor;
  std::atomic<int> ticks{0};
  const auto id = executor.addTimer(0.01, [&] { ++ticks; });
  ASSERT_TRUE(waitFor([&] { return ticks >= 5; }));
  executor.cancelTimer(id);
  executor.drain();
  const int after_cancel = ticks;
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(ticks, after_cancel);
  EXPECT_THROW(executor.addTimer(0.0, [] {}), std::invalid_argument);
}

TEST(RuntimeExecutor, RunsTasksInOrderAndSurvivesExceptions) {
  Executor executor;
  std::vector<int> order;
  for (int i = 0; i < 100; ++i) {
    executor.post([&order, i] {
      if (i == 50) throw std::runtime_error("task 50 fails on purpose");
      order.push_back(i);
    });
  }
  executor.drain();
  ASSERT_EQ(order.size(), 99u);
  EXPECT_EQ(order.front(), 0);
  EXPECT_EQ(order.back(), 99);
  executor.shutdown();
  executor.post([&order] { order.push_back(-1); });  // ignored after shutdown
  EXPECT_EQ(order.size(), 99u);
}

// A task queued by invoke() and dropped by shutdown() must not leave its caller waiting.
TEST(RuntimeExecutor, InvokeDroppedByShutdownThrowsInsteadOfWaiting) {
  Executor executor(1);
  std::atomic<bool> blocking{false}, release{false};
  executor.post([&] {
    blocking = true;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  ASSERT_TRUE(waitFor([&] { return blocking.load(); }));
  std::atomic<bool> ran{false};
  std::atomic<int> outcome{0};  // 1: returned, 2: threw runtime_error
  std::thread caller([&] {
    try {
      executor.invoke([&] { ran = true; });
      outcome = 1;
    } catch (const std::runtime_error&) {
      outcome = 2;
    }
  });
  // Time for the caller to queue its task behind the blocking one.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::thread stopper([&] { executor.shutdown(); });
  // The caller hears of it while the worker is still busy (shutdown waits for it).
  EXPECT_TRUE(waitFor([&] { return outcome != 0; }));
  EXPECT_EQ(outcome, 2);
  EXPECT_FALSE(ran);
  release = true;
  stopper.join();
  caller.join();
}

}  // namespace
}  // namespace storey::runtime

namespace storey::runtime {
namespace {

TEST(RuntimeContext, DomainIdComesFromOptionsThenRosDomainId) {
  const char* saved = std::getenv("ROS_DOMAIN_ID");
  const std::string restore = saved ? saved : "";
  unsetenv("ROS_DOMAIN_ID");
  EXPECT_EQ(resolveDomainId(-1), 0);
  setenv("ROS_DOMAIN_ID", "42", 1);
  EXPECT_EQ(resolveDomainId(-1), 42);
  EXPECT_EQ(resolveDomainId(7), 7);
  setenv("ROS_DOMAIN_ID", "forty", 1);
  EXPECT_THROW(resolveDomainId(-1), DdsError);
  setenv("ROS_DOMAIN_ID", "300", 1);
  EXPECT_THROW(resolveDomainId(-1), DdsError);
  if (saved) {
    setenv("ROS_DOMAIN_ID", restore.c_str(), 1);
  } else {
    unsetenv("ROS_DOMAIN_ID");
  }
}

TEST(RuntimeContext, MissingQosFileIsNamed) {
  ContextOptions options;
  options.domain_id = 106;
  options.qos_profiles_file = "/nonexistent/qos.xml";
  try {
    Context context(options);
    FAIL() << "a missing QoS file was accepted";
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/qos.xml"), std::string::npos) << e.what();
  }
}

// A QoS file's participant profile named storey_participant configures the participant
// (Fast DDS 2.9 leaves a file's is_default_profile participant unapplied, so a test's 3 s
// lease and UDP-only transport would silently not be in effect).
TEST(RuntimeContext, ParticipantProfileOfTheQosFileApplies) {
  const std::string path = test::makeTempDir("qos") + "/participant.xml";
  std::ofstream(path) << R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor><transport_id>udp_only</transport_id><type>UDPv4</type></transport_descriptor>
    </transport_descriptors>
    <participant profile_name="storey_participant">
      <rtps>
        <userTransports><transport_id>udp_only</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
        <builtin><discovery_config><leaseDuration><sec>7</sec></leaseDuration></discovery_config></builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
)";
  ContextOptions options = optionsForDomain(118);
  options.qos_profiles_file = path;
  options.participant_name = "profiled";
  Context context(options);
  const auto qos = context.participant().get_qos();
  EXPECT_EQ(qos.wire_protocol().builtin.discovery_config.leaseDuration.seconds, 7);
  EXPECT_FALSE(qos.transport().use_builtin_transports);
  EXPECT_EQ(qos.transport().user_transports.size(), 1u);
  EXPECT_EQ(qos.name().to_string(), "profiled");  // the options' name wins over the profile's
}

}  // namespace
}  // namespace storey::runtime

namespace storey::runtime {
namespace {

// The bytes ROS 2 puts on the wire for sensor_msgs/FluidPressure (little-endian CDR:
// encapsulation header, Time, frame_id string with its NUL, padding to 8, two doubles).
TEST(RuntimeWire, FluidPressureSerialisesAsRos2Does) {
  sensor_msgs::msg::FluidPressure message;
  message.header().stamp().sec(5);
  message.header().stamp().nanosec(7);
  message.header().frame_id("b");
  message.fluid_pressure(101325.0);
  message.variance(9.0);
  sensor_msgs::msg::FluidPressurePubSubType type;
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(&message)());
  ASSERT_TRUE(type.serialize(&message, &payload));
  std::vector<unsigned char> expected = {0x00, 0x01, 0x00, 0x00,  // CDR_LE
                                         5,    0,    0,    0,     // sec
                                         7,    0,    0,    0,     // nanosec
                                         2,    0,    0,    0,     // frame_id length
                                         'b',  0,    0,    0};    // "b\0" + padding to 8
  auto append = [&](double value) {
    unsigned char bytes[8];
    std::memcpy(bytes, &value, 8);
    expected.insert(expected.end(), bytes, bytes + 8);
  };
  append(101325.0);
  append(9.0);
  ASSERT_EQ(payload.length, expected.size());
  EXPECT_EQ(std::vector<unsigned char>(payload.data, payload.data + payload.length), expected);

  sensor_msgs::msg::FluidPressure back;
  ASSERT_TRUE(type.deserialize(&payload, &back));
  EXPECT_EQ(back, message);
}

}  // namespace
}  // namespace storey::runtime
