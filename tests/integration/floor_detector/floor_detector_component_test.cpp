#include "storey/floor_detector/floor_detector_component.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <cmath>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

#include "storey/catalog/all_components.h"
#include "storey/detection/barometer.h"
#include "storey/runtime/floor_event_conversions.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/subscription.h"
#include "test_support.h"

namespace storey::floor_detector {
namespace {

using EventMsg = storey_msgs::msg::FloorEvent;
using geometry::Pose2;
using EventSub = runtime::Subscription<EventMsg, storey_msgs::msg::FloorEventPubSubType>;

runtime::ContextOptions onDomain(int domain) {
  runtime::ContextOptions options;
  options.domain_id = domain;
  return options;
}

// The shipped parameters with another robot name (and, for a robot without one, no
// barometer).
common::ConfigNode parametersFor(const std::string& robot, bool barometer = true) {
  std::ifstream in(test::sourceDir() + "/config/floor_detector.yaml");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const std::string key = "robot: robot1";
  text.replace(text.find(key), key.size(), "robot: " + robot);
  if (!barometer) text.replace(text.find("barometer: true"), 15, "barometer: false");
  return common::ConfigNode::loadString(text, "floor_detector.yaml");
}

// Height of a 3 m elevator ride starting at 30 s: 0.5 m/s^2 up to 1 m/s, 4 s in all.
double rideHeight(double t) {
  const double tau = t - 30.0;
  if (tau <= 0.0) return 0.0;
  if (tau < 2.0) return 0.25 * tau * tau;
  if (tau < 2.0 + 1.0) return 1.0 + (tau - 2.0);
  if (tau < 4.0 + 1.0) return 3.0 - 0.25 * (5.0 - tau) * (5.0 - tau);
  return 3.0;
}
double rideAcceleration(double t) {
  const double tau = t - 30.0;
  if (tau > 0.0 && tau < 2.0) return 0.5;
  if (tau > 3.0 && tau < 5.0) return -0.5;
  return 0.0;
}

// Publishes 75 s of pressure (10 Hz, 2 Pa noise) and IMU (50 Hz) at 25x real time.
void publishRide(runtime::Context& context, const std::string& robot) {
  runtime::Publisher<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType>
      pressure(context, "/" + robot + "/pressure", runtime::TopicKind::kSensor);
  runtime::Publisher<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType> imu(
      context, "/" + robot + "/imu", runtime::TopicKind::kSensor);
  ASSERT_TRUE(pressure.waitForSubscribers(1, 5.0));
  ASSERT_TRUE(imu.waitForSubscribers(1, 5.0));
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int step = 0; step <= 750; ++step) {
    const double t = 100.0 + step * 0.1;  // stamps need not start at 0
    const double p = detection::pressureAtHeight(rideHeight(t - 100.0), 288.15) + 2.0 * noise(rng);
    pressure.publish(runtime::toMessage(sensor::PressureSample{t, p, 4.0}));
    for (int k = 0; k < 5; ++k) {
      sensor::ImuSample sample;
      sample.stamp = t + 0.02 * k;
      sample.linear_acceleration = Eigen::Vector3d(
          0.05 * noise(rng), 0.05 * noise(rng),
          detection::kStandardGravity + rideAcceleration(sample.stamp - 100.0) + 0.05 * noise(rng));
      imu.publish(runtime::toMessage(sample));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
  }
}

// The same ride for a robot without a barometer: IMU (50 Hz) and odometry (20 Hz, standing).
void publishImuRide(runtime::Context& context, const std::string& robot) {
  runtime::Publisher<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType> imu(
      context, "/" + robot + "/imu", runtime::TopicKind::kSensor);
  runtime::Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom(
      context, "/" + robot + "/odom", runtime::TopicKind::kSensor);
  ASSERT_TRUE(imu.waitForSubscribers(1, 5.0));
  ASSERT_TRUE(odom.waitForSubscribers(1, 5.0));
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (int step = 0; step <= 750; ++step) {
    const double t = 100.0 + step * 0.1;
    for (int k = 0; k < 2; ++k) {
      sensor::OdometrySample sample;
      sample.stamp = t + 0.05 * k;
      odom.publish(runtime::toMessage(sample, "odom", "base_link"));
    }
    for (int k = 0; k < 5; ++k) {
      sensor::ImuSample sample;
      sample.stamp = t + 0.02 * k;
      sample.linear_acceleration = Eigen::Vector3d(
          noise(rng), noise(rng),
          detection::kStandardGravity + rideAcceleration(sample.stamp - 100.0) + noise(rng));
      imu.publish(runtime::toMessage(sample));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
  }
}

bool waitFor(const std::function<bool()>& done, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

TEST(FloorDetectorComponent, PublishesTheRideAndLateSubscribersGetIt) {
  runtime::Context context(onDomain(230));
  std::mutex mutex;
  std::vector<EventMsg> received;
  std::vector<double> progress;  // decided_at of every message, events and progress alike
  EventSub events(context, "/fd_robot/floor_events", runtime::TopicKind::kGraph,
                  [&](const EventMsg& m) {
                    std::lock_guard<std::mutex> lock(mutex);
                    progress.push_back(runtime::fromTimeMessage(m.decided_at()));
                    if (m.kind() != storey_msgs::msg::FloorEvent_Constants::KIND_PROGRESS) received.push_back(m);
                  });
  FloorDetectorComponent component(context, parametersFor("fd_robot"), "detector");
  component.configure();
  component.activate();
  publishRide(context, "fd_robot");
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return received.size() >= 2;
      },
      10.0));
  {
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_EQ(received.size(), 2u);
    namespace k = storey_msgs::msg::FloorEvent_Constants;
    EXPECT_EQ(received[0].kind(), k::KIND_TRANSIT_STARTED);
    EXPECT_EQ(received[0].robot(), "fd_robot");
    EXPECT_EQ(received[1].kind(), k::KIND_TRANSIT_ENDED);
    EXPECT_EQ(received[1].floor_id(), 1);
    EXPECT_TRUE(received[1].new_floor());
    EXPECT_NEAR(received[1].height_change(), 3.0, 0.25);
    EXPECT_EQ(received[1].mode(), k::MODE_ELEVATOR);
    const double start = runtime::fromTimeMessage(received[0].stamp());
    const double end = runtime::fromTimeMessage(received[1].stamp());
    EXPECT_LE(start, 130.0);
    EXPECT_GE(end, 134.0);
    // Each event was decided after it began, and the detector's progress (on the same
    // topic, so the mapper can order scans and events by stamp) only moves forward, about
    // every progress_period (0.5 s) of the 75 s ride recording.
    EXPECT_GT(runtime::fromTimeMessage(received[0].decided_at()), start);
    EXPECT_GT(runtime::fromTimeMessage(received[1].decided_at()), end);
  }
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return !progress.empty() && progress.back() >= 174.0;
      },
      5.0));
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
    EXPECT_GE(progress.size(), 100u);  // 75 s / 0.5 s, less samples the best-effort topic lost
    EXPECT_LE(progress.size(), 153u);
  }
  EXPECT_EQ(component.currentFloor(), 1);
  EXPECT_EQ(component.eventsPublished(), 2u);

  // Transient local: a subscriber that joins after the ride still gets both events.
  std::vector<EventMsg> late;
  EventSub late_events(context, "/fd_robot/floor_events", runtime::TopicKind::kGraph,
                       [&](const EventMsg& m) {
                         std::lock_guard<std::mutex> lock(mutex);
                         late.push_back(m);
                       });
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return late.size() >= 2;
      },
      5.0));
  component.deactivate();
  component.cleanup();
}

TEST(FloorDetectorComponent, ARobotWithoutABarometerPublishesTheRideFromItsImu) {
  runtime::Context context(onDomain(59));
  std::mutex mutex;
  std::vector<EventMsg> received;
  double progress = 0.0;
  EventSub events(context, "/fd_imu/floor_events", runtime::TopicKind::kGraph,
                  [&](const EventMsg& m) {
                    std::lock_guard<std::mutex> lock(mutex);
                    progress = runtime::fromTimeMessage(m.decided_at());
                    if (m.kind() != storey_msgs::msg::FloorEvent_Constants::KIND_PROGRESS)
                      received.push_back(m);
                  });
  FloorDetectorComponent component(context, parametersFor("fd_imu", false), "detector");
  component.configure();
  component.activate();
  publishImuRide(context, "fd_imu");
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return received.size() >= 2 && progress >= 174.0;
      },
      10.0));
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(received.size(), 2u);
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  EXPECT_EQ(received[0].kind(), k::KIND_TRANSIT_STARTED);
  EXPECT_EQ(received[1].kind(), k::KIND_TRANSIT_ENDED);
  EXPECT_EQ(received[1].floor_id(), 1);
  EXPECT_NEAR(received[1].height_change(), 3.0, 0.25);
  EXPECT_EQ(received[1].mode(), k::MODE_ELEVATOR);
}

// A robot without a barometer climbs 3 m of stairs (6 m along a 30 degree slope); its IMU
// is mounted turned 90 degrees (its x axis along the robot's left), which tf_static says.
// The forward force is read from the IMU's y axis: without the mounting there is no climb.
TEST(FloorDetectorComponent, TakesTheImuMountingFromTfStatic) {
  runtime::Context context(onDomain(65));
  std::mutex mutex;
  std::vector<EventMsg> received;
  EventSub events(context, "/fd_mount/floor_events", runtime::TopicKind::kGraph,
                  [&](const EventMsg& m) {
                    std::lock_guard<std::mutex> lock(mutex);
                    if (m.kind() != storey_msgs::msg::FloorEvent_Constants::KIND_PROGRESS)
                      received.push_back(m);
                  });
  FloorDetectorComponent component(context, parametersFor("fd_mount", false), "detector");
  component.configure();
  component.activate();
  runtime::Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_static(
      context, "/tf_static", runtime::TopicKind::kGraph);
  tf2_msgs::msg::TFMessage mounting;
  mounting.transforms().push_back(
      runtime::toTransform(Pose2(0.1, 0.0, M_PI / 2), 0.0, "fd_mount/base_link", "fd_mount/imu"));
  tf_static.publish(mounting);
  runtime::Publisher<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType> imu(
      context, "/fd_mount/imu", runtime::TopicKind::kSensor);
  runtime::Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom(
      context, "/fd_mount/odom", runtime::TopicKind::kSensor);
  ASSERT_TRUE(imu.waitForSubscribers(1, 5.0));
  ASSERT_TRUE(odom.waitForSubscribers(1, 5.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // tf_static first
  const double slope = M_PI / 6, speed = 0.25;
  auto along = [&](double t) { return speed * std::clamp(t - 10.0, 0.0, 24.0); };
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (int step = 0; step <= 650; ++step) {
    const double t = step * 0.1;
    for (int k = 0; k < 2; ++k) {
      sensor::OdometrySample sample;
      sample.stamp = 100.0 + t + 0.05 * k;
      sample.pose = Pose2(along(t + 0.05 * k), 0.0, 0.0);
      odom.publish(runtime::toMessage(sample, "fd_mount/odom", "fd_mount/base_link"));
    }
    for (int k = 0; k < 5; ++k) {
      const double u = t + 0.02 * k;
      const bool climbing = u > 10.0 && u < 34.0;
      const double forward = climbing ? detection::kStandardGravity * std::sin(slope) : 0.0;
      const double up = detection::kStandardGravity * (climbing ? std::cos(slope) : 1.0);
      sensor::ImuSample sample;
      sample.stamp = 100.0 + u;
      sample.linear_acceleration =
          Eigen::Vector3d(noise(rng), -forward + noise(rng), up + noise(rng));
      imu.publish(runtime::toMessage(sample, "fd_mount/imu"));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(4));
  }
  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return received.size() >= 2;
      },
      10.0));
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(received[1].kind(), storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_ENDED);
  EXPECT_EQ(received[1].floor_id(), 1);
  EXPECT_TRUE(received[1].new_floor());
  EXPECT_NEAR(received[1].height_change(), 3.0, 0.3);
}

TEST(FloorDetectorComponent, NothingIsProcessedBeforeActivation) {
  runtime::Context context(onDomain(231));
  std::atomic<int> received{0};
  EventSub events(context, "/idle_robot/floor_events", runtime::TopicKind::kGraph,
                  [&](const EventMsg&) { ++received; });
  FloorDetectorComponent component(context, parametersFor("idle_robot"), "detector");
  component.configure();
  publishRide(context, "idle_robot");
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(received.load(), 0);
  EXPECT_EQ(component.currentFloor(), 0);
  component.cleanup();
}

TEST(FloorDetectorComponent, BadParametersNameTheKey) {
  runtime::Context context(onDomain(232));
  FloorDetectorComponent component(
      context, common::ConfigNode::loadString("{robot: r, events_topic: e}", "p.yaml"), "d");
  try {
    component.configure();
    FAIL() << "configured without a detector mapping";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("detector"), std::string::npos) << e.what();
  }
}

TEST(FloorDetectorComponent, RegisteredInTheCatalog) {
  runtime::ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  EXPECT_TRUE(registry.has("floor_detector"));
}

TEST(FloorDetectorConversions, RoundTrip) {
  detection::FloorEvent e;
  e.type = detection::FloorEventType::kTransitEnded;
  e.stamp = 12.5;
  e.floor_id = 3;
  e.new_floor = true;
  e.floor_changed = true;
  e.height_change = -3.5;
  e.height_change_stddev = 0.07;
  e.floor_height = 4.0;
  e.confidence = 0.9;
  e.mode = detection::TransitMode::kStairs;
  e.decided_at = 14.0;
  const detection::FloorEvent back = runtime::fromMessage(runtime::toMessage(e, "r"));
  EXPECT_EQ(back.type, e.type);
  EXPECT_DOUBLE_EQ(back.stamp, e.stamp);
  EXPECT_EQ(back.floor_id, 3);
  EXPECT_TRUE(back.new_floor);
  EXPECT_DOUBLE_EQ(back.height_change, -3.5);
  EXPECT_DOUBLE_EQ(back.height_change_stddev, 0.07);
  EXPECT_DOUBLE_EQ(back.floor_height, 4.0);
  EXPECT_DOUBLE_EQ(back.confidence, 0.9);
  EXPECT_EQ(back.mode, detection::TransitMode::kStairs);
  EXPECT_DOUBLE_EQ(back.decided_at, 14.0);
  detection::FloorEvent s;
  s.stamp = 3.0;
  EXPECT_EQ(runtime::toMessage(s, "r").floor_id(), -1);
  // A publisher that leaves decided_at zero: the event's stamp stands in for it.
  EXPECT_DOUBLE_EQ(runtime::fromMessage(runtime::toMessage(s, "r")).decided_at, 3.0);
  detection::FloorEvent p;
  p.type = detection::FloorEventType::kProgress;
  p.stamp = p.decided_at = 20.0;
  EXPECT_EQ(runtime::fromMessage(runtime::toMessage(p, "r")).type, detection::FloorEventType::kProgress);
  // An unsure arrival's candidates, the wait for its answer, and the answer.
  e.candidate_floors = {3, 1};
  e.new_floor_id = 5;
  e.new_floor_height = 7.5;
  const detection::FloorEvent unsure = runtime::fromMessage(runtime::toMessage(e, "r"));
  EXPECT_EQ(unsure.candidate_floors, (std::vector<int>{3, 1}));
  EXPECT_EQ(unsure.new_floor_id, 5);
  EXPECT_DOUBLE_EQ(unsure.new_floor_height, 7.5);
  EXPECT_FALSE(back.identityUnsure());
  detection::FloorEvent w;
  w.type = detection::FloorEventType::kAwaitingIdentity;
  w.stamp = 12.5;
  w.decided_at = 40.0;
  const detection::FloorEvent waiting = runtime::fromMessage(runtime::toMessage(w, "r"));
  EXPECT_EQ(waiting.type, detection::FloorEventType::kAwaitingIdentity);
  EXPECT_DOUBLE_EQ(waiting.stamp, 12.5);
  const floor::FloorIdentity answer =
      runtime::fromMessage(runtime::toMessage(floor::FloorIdentity{12.5, 1, true}, "r"));
  EXPECT_DOUBLE_EQ(answer.ride_end, 12.5);
  EXPECT_EQ(answer.floor_id, 1);
  EXPECT_TRUE(answer.localized);
  storey_msgs::msg::FloorIdentity negative;
  negative.floor_id(-1);
  EXPECT_THROW(runtime::fromMessage(negative), std::invalid_argument);
  storey_msgs::msg::FloorEvent bad;
  bad.kind(9);
  EXPECT_THROW(runtime::fromMessage(bad), std::invalid_argument);
  bad.kind(storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_ENDED);
  bad.floor_height(std::numeric_limits<double>::quiet_NaN());
  EXPECT_THROW(runtime::fromMessage(bad), std::invalid_argument);
}

}  // namespace
}  // namespace storey::floor_detector
