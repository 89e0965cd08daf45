#include "storey/floor_detector/floor_detector_component.h"

#include <fstream>

#include "storey/common/log.h"
#include "storey/runtime/floor_event_conversions.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_detector {

using common::str;

FloorDetectorComponentOptions readFloorDetectorComponentOptions(const common::ConfigNode& node) {
  FloorDetectorComponentOptions o;
  o.robot = node.get<std::string>("robot");
  o.topics = runtime::readSensorTopics(node, o.robot, o.topics, true);
  o.events_topic = node.get<std::string>("events_topic");
  if (o.events_topic.empty()) node.fail("events_topic", "must not be empty");
  try {
    runtime::robotTopic(o.robot, o.events_topic);
  } catch (const std::invalid_argument& e) {
    node.fail("events_topic", e.what());
  }
  o.progress_period = node.getDouble("progress_period", o.progress_period, 0.01, 60.0);
  o.state_file = node.get<std::string>("state_file", o.state_file);
  o.identity_wait = node.getDouble("identity_wait", o.identity_wait, 0.0, 3600.0);
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
    detector_->awaitIdentity(options_.identity_wait);
    published_ = 0;
    last_progress_ = -1e300;
    if (!options_.state_file.empty() && std::ifstream(options_.state_file).good()) {
      const detection::FloorDetectorState state = detection::readFloorDetectorState(options_.state_file);
      detector_->resume(state);
      last_progress_ = state.saved_at;
      common::logInfo(str(name(), ": resumed from ", options_.state_file, " on floor ",
                          state.floors[static_cast<std::size_t>(state.current_floor)].id,
                          state.in_transit ? " in a ride" : "", ", state of t=", state.saved_at));
    }
  }
  const std::string& robot = options_.robot;
  publisher_ =
      createPublisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>(
          runtime::robotTopic(robot, options_.events_topic), runtime::TopicKind::kGraph);
  // Samples that arrive before activation are dropped: their events could not be sent.
  auto active = [this] {
    if (state() == runtime::LifecycleState::kActive) return true;
    ++dropped_inactive_;
    return false;
  };
  pressure_subscription_ = createSubscription<sensor_msgs::msg::FluidPressure,
                                              sensor_msgs::msg::FluidPressurePubSubType>(
      runtime::robotTopic(robot, options_.topics.pressure), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::FluidPressure& m) {
        if (!active()) return;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          detector_->addPressure(runtime::fromMessage(m));
        }
        publishEvents();
      });
  createSubscription<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType>(
      runtime::robotTopic(robot, options_.topics.imu), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::Imu& m) {
        if (!active()) return;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          detector_->addImu(imuInBase(m));
        }
        if (!options_.detector.sensors.barometer) publishEvents();  // the IMU is the clock
      });
  createSubscription<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>(
      runtime::robotTopic(robot, options_.topics.odom), runtime::TopicKind::kSensor,
      [this, active](const nav_msgs::msg::Odometry& m) {
        if (!active()) return;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          odometry_frame_ = m.child_frame_id();
          detector_->addOdometry(runtime::fromMessage(m));
        }
        if (!options_.detector.sensors.barometer) publishEvents();  // IMU samples wait for it
      });
  createSubscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>(
      runtime::robotTopic(robot, options_.topics.scan), runtime::TopicKind::kSensor,
      [this, active](const sensor_msgs::msg::LaserScan& m) {
        if (!active()) return;
        std::lock_guard<std::mutex> lock(mutex_);
        detector_->addScan(runtime::fromMessage(m));
      });
  // The floor mapper's answers to unsure arrivals; taken in any state, like its events.
  createSubscription<storey_msgs::msg::FloorIdentity, storey_msgs::msg::FloorIdentityPubSubType>(
      runtime::robotTopic(robot, "floor_identity"), runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::FloorIdentity& m) {
        try {
          const floor::FloorIdentity identity = runtime::fromMessage(m);
          std::lock_guard<std::mutex> lock(mutex_);
          detector_->setFloorIdentity(identity);
        } catch (const std::invalid_argument& e) {
          common::logWarn(str(name(), ": ignoring a floor identity: ", e.what()));
          return;
        }
        publishEvents();
      });
  createSubscription<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>(
      "tf_static", runtime::TopicKind::kGraph, [this](const tf2_msgs::msg::TFMessage& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        runtime::addStaticTransforms(m, &frames_, name());
      });
  common::logInfo(str(name(), ": detecting floor changes of '", robot, "', events on ",
                      runtime::robotTopic(robot, options_.events_topic)));
}

// An IMU frame mounted on the base (tf_static, a chain allowed) is turned into the base
// frame; one that is a base frame itself, or whose mounting is not known (yet), is taken
// as it is, the latter with one warning.
sensor::ImuSample FloorDetectorComponent::imuInBase(const sensor_msgs::msg::Imu& message) {
  sensor::ImuSample sample = runtime::fromMessage(message);
  const std::string& frame = message.header().frame_id();
  if (const auto mounting =
          frames_.poseInFirstOf(frame, runtime::robotBaseFrames(options_.robot, odometry_frame_))) {
    return sensor::rotatedByYaw(sample, mounting->theta());
  }
  if (!imu_mounting_warned_ && !frame.empty()) {
    common::logWarn(str(name(), ": no tf_static mounting of IMU frame '", frame,
                        "' on the robot's base; its axes are taken as the base's"));
    imu_mounting_warned_ = true;
  }
  return sample;
}

void FloorDetectorComponent::onCleanup() {
  std::lock_guard<std::mutex> lock(mutex_);
  // What the detector saw: a restarted or silent detector is diagnosed from this line.
  if (detector_) {
    const auto& s = detector_->stats();
    const std::uint64_t received = pressure_subscription_ ? pressure_subscription_->receivedCount() : 0;
    const int writers = pressure_subscription_ ? pressure_subscription_->matchedCount() : 0;
    common::logInfo(
        str(name(), ": ", received, " pressure samples received from ", writers, " writer(s) (",
            s.pressure_samples,
            options_.detector.sensors.barometer ? " processed, " : " IMU heights processed, ",
            s.rejected_pressure, " rejected, ", s.before_resume, " before the resumed state), ",
            dropped_inactive_.load(), " samples dropped while inactive, ", published_,
            " floor events published, processed until t=", detector_->processedUntil()));
  }
  pressure_subscription_.reset();
  detector_.reset();
  publisher_.reset();
}

void FloorDetectorComponent::publishEvents() {
  std::vector<detection::FloorEvent> events;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!detector_) return;
    events = detector_->takeEvents();
    // Every event is progress too; between events, one progress message per period.
    const double until = detector_->processedUntil();
    if (!events.empty()) {
      last_progress_ = events.back().decided_at;
    } else if (until - last_progress_ >= options_.progress_period) {
      detection::FloorEvent progress;
      progress.type = detection::FloorEventType::kProgress;
      progress.stamp = until;
      progress.decided_at = until;
      events.push_back(progress);
      last_progress_ = until;
    }
    if (!events.empty() && !options_.state_file.empty()) saveState();
  }
  for (const auto& event : events) {
    if (publisher_ && publisher_->publish(runtime::toMessage(event, options_.robot))) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (event.type != detection::FloorEventType::kProgress) ++published_;
    }
  }
}

void FloorDetectorComponent::saveState() {
  try {
    detection::writeFloorDetectorState(options_.state_file, detector_->state());
  } catch (const std::runtime_error& e) {
    common::logWarn(str(name(), ": ", e.what()));
  }
}

}  // namespace storey::floor_detector
