// A robot's names the ROS way: its topics (relative to its namespace, or absolute) and
// frames, and the sensor topic keys floor_detector and floor_mapper read.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "storey/common/config.h"

namespace storey::runtime {

// A robot's topic as ROS names go: a relative `leaf` is "/<robot>/<leaf>" ("/<leaf>" for
// robot ""), an absolute one (leading '/') itself. Throws std::invalid_argument for a
// robot or leaf that is not a ROS 2 name (tokens of letters, digits, '_', joined by '/').
std::string robotTopic(const std::string& robot, const std::string& leaf);

// A robot's sensor topics as its parameters name them (relative or absolute, as
// robotTopic takes them): floor_detector's and floor_mapper's scan_topic, odom_topic,
// imu_topic, pressure_topic.
struct SensorTopics {
  std::string scan = "scan";
  std::string odom = "odom";
  std::string imu = "imu";
  std::string pressure = "pressure";
};

// The robot whose `leaf` names `topic`: the namespace before a relative leaf ("" when the
// topic is "/<leaf>"), "" when an absolute leaf is the topic; nullopt when it names another.
std::optional<std::string> robotOfTopic(const std::string& topic, const std::string& leaf);
std::string robotFrame(const std::string& robot, const std::string& frame);
// The frames a sensor may be mounted on, first choice first: the frame the odometry moves
// (its child_frame_id, "" if unknown), then base_footprint and base_link, in the robot's
// namespace and without one (a single robot's standard frames carry none).
std::vector<std::string> robotBaseFrames(const std::string& robot,
                                         const std::string& odometry_frame);

// The scan_topic and odom_topic keys (and with `imu_and_pressure`, imu_topic and
// pressure_topic), each optional with `defaults`' value, checked as robot's topic names;
// errors name the key (`robot` when the robot's name is no ROS 2 namespace).
SensorTopics readSensorTopics(const common::ConfigNode& node, const std::string& robot,
                              SensorTopics defaults, bool imu_and_pressure);

}  // namespace storey::runtime
