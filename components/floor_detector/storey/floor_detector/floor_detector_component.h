// floor_detector component: subscribes a robot's pressure, IMU, odometry and scan topics
// (best effort), runs detection::FloorDetector, and publishes storey_msgs/FloorEvent on
// /<robot>/<events_topic> (reliable, transient local, so a late floor_mapper gets every
// event). Now and then (progress_period of sensor time) it sends a progress message on the
// same topic, so the floor_mapper can apply each event between the right scans whatever
// the delivery timing. Parameters: config/floor_detector.yaml. Samples are processed only
// while active.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>

#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/FluidPressurePubSubTypes.h"
#include "sensor_msgs/msg/ImuPubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/common/shipped_config.h"
#include "storey/detection/floor_detector.h"
#include "storey/geometry/frame_tree.h"
#include "storey/runtime/component.h"
#include "storey/runtime/sensor_bag.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "storey_msgs/msg/FloorIdentityPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::floor_detector {

struct FloorDetectorComponentOptions {
  std::string robot;                          // topic namespace
  // Sensor topics in; relative to the robot's namespace, or absolute (runtime::robotTopic).
  runtime::SensorTopics topics{
      shipped::floor_detector::scan_topic, shipped::floor_detector::odom_topic,
      shipped::floor_detector::imu_topic, shipped::floor_detector::pressure_topic};
  // under the robot's namespace
  std::string events_topic = shipped::floor_detector::events_topic;
  // s of sensor time between progress messages (optional key)
  double progress_period = shipped::floor_detector::progress_period;
  // Where the detector keeps its state (floors, current floor, barometric reference) so a
  // restarted detector goes on from it; "" = none (optional key).
  std::string state_file = shipped::floor_detector::state_file;
  // s of sensor time the detector waits, before the next ride, for the floor mapper's
  // answer to an unsure arrival (<robot>/floor_identity); 0: never waits (no mapper).
  double identity_wait = shipped::floor_detector::identity_wait;
  detection::FloorDetectorOptions detector;
};
// Reads robot, the *_topic keys, progress_period, state_file, identity_wait and detector;
// calls finish().
FloorDetectorComponentOptions readFloorDetectorComponentOptions(const common::ConfigNode& node);

class FloorDetectorComponent : public runtime::Component {
 public:
  FloorDetectorComponent(runtime::Context& context, const common::ConfigNode& parameters,
                         std::string name);

  int currentFloor() const;
  std::uint64_t eventsPublished() const;
  const FloorDetectorComponentOptions& options() const { return options_; }

 protected:
  void onConfigure() override;
  void onCleanup() override;

 private:
  void publishEvents();

  FloorDetectorComponentOptions options_;
  mutable std::mutex mutex_;  // guards detector_ (callbacks may run on several threads)
  std::unique_ptr<detection::FloorDetector> detector_;
  std::shared_ptr<
      runtime::Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>>
      publisher_;
  std::uint64_t published_ = 0;
  std::atomic<std::uint64_t> dropped_inactive_{0};  // sensor samples that came before activation
  // The IMU's mounting, as in ROS 2 from tf_static: its samples are turned into the base
  // frame (a yaw; the detector reads the forward axis on slopes). Guarded by mutex_.
  geometry::FrameTree frames_;
  std::string odometry_frame_;  // the odometry's child_frame_id
  bool imu_mounting_warned_ = false;
  sensor::ImuSample imuInBase(const sensor_msgs::msg::Imu& message);
  std::shared_ptr<runtime::SubscriptionBase> pressure_subscription_;
  double last_progress_ = -1e300;  // decided_at of the last message sent
  void saveState();                  // with mutex_ held
};

}  // namespace storey::floor_detector
