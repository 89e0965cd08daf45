#include "storey/floor_detector/floor_detector_component.h"

#include "storey/common/log.h"
#include "storey/floor_detector/conversions.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_detector {

using common::str;

FloorDetectorComponentOptions readFloorDetectorComponentOptions(const common::ConfigNode& node) {
  FloorDetectorComponentOptions o;
  o.robot = node.get<std::string>("robot");
  o.events_topic = node.get<std::string>("events_topic");
  if (o.events_topic.empty()) node.fail("events_topic", "must not be empty");
  try {
    runtime::robotTopic(o.robot, o.events_topic);
  } catch (const std::invalid_argument& e) {
    node.fail("robot", e.what());
  }
  o.detector = detection::readFloorDetectorOptions(node.child("detector"));
  node.finish();
  return o;
}

FloorDetectorComponent::FloorDetectorComponent(runtime::Context& context,
                                               const common::ConfigNode& parameters,
                                               std::string name)
    : runtime::Component(context, parameters, std::move(name)) {}

int FloorDetectorComponent::currentFloor() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return detector_ ? detector_->currentFloor() : 0;
}

std::uint64_t FloorDetectorComponent::eventsPublished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return published_;
}

void FloorDetectorComponent::onConfigure() {
  options_ = readFloorDetectorComponentOptions(parameters());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    detector_ = std::make_unique<detection::FloorDetector>(options_.detector);
    published_ = 0;
  }
  const std::string& robot = options_.robot;
  publisher_ =
      createPublisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>(
          runtime::robotTopic(robot, options_.events_topic), runtime::TopicKind::kGraph);
  // Samples that arrive before activation are dropped: their events could not be sent.
  auto active = [this] { return state() == runtime::LifecycleState::kActive; };
  createSubscription<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType>(
      runtime::robotTopic(robot, "pressure"), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::FluidPressure& m) {
        if (!active()) return;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          detector_->addPressure(runtime::fromMessage(m));
        }
        publishEvents();
      });
  createSubscription<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType>(
      runtime::robotTopic(robot, "imu"), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::Imu& m) {
        if (!active()) return;
        std::lock_guard<std::mutex> lock(mutex_);
        detector_->addImu(runtime::fromMessage(m));
      });
  createSubscription<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>(
      runtime::robotTopic(robot, "odom"), runtime::TopicKind::kSensor,
      [this, active](const nav_msgs::msg::Odometry& m) {
        if (!active()) return;
        std::lock_guard<std::mutex> lock(mutex_);
        detector_->addOdometry(runtime::fromMessage(m));
      });
  createSubscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>(
      runtime::robotTopic(robot, "scan"), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::LaserScan& m) {
        if (!active()) return;
        std::lock_guard<std::mutex> lock(mutex_);
        detector_->addScan(runtime::fromMessage(m));
      });
  common::logInfo(str(name(), ": detecting floor changes of '", robot, "', events on ",
                      runtime::robotTopic(robot, options_.events_topic)));
}

void FloorDetectorComponent::onCleanup() {
  std::lock_guard<std::mutex> lock(mutex_);
  detector_.reset();
  publisher_.reset();
}

void FloorDetectorComponent::publishEvents() {
  std::vector<detection::FloorEvent> events;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!detector_) return;
    events = detector_->takeEvents();
  }
  for (const auto& event : events) {
    if (publisher_ && publisher_->publish(toMessage(event, options_.robot))) {
      std::lock_guard<std::mutex> lock(mutex_);
      ++published_;
    }
  }
}

}  // namespace storey::floor_detector
