#include "storey/runtime/sensor_topics.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace storey::runtime {
namespace {

bool validRobotName(const std::string& robot) {
  if (robot.empty()) return true;
  std::size_t start = 0;
  while (start <= robot.size()) {
    const std::size_t end = std::min(robot.find('/', start), robot.size());
    if (end == start) return false;  // empty token
    if (std::isdigit(static_cast<unsigned char>(robot[start]))) return false;
    for (std::size_t i = start; i < end; ++i) {
      const char c = robot[i];
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
    }
    start = end + 1;
  }
  return true;
}

void checkRobot(const std::string& robot) {
  if (!validRobotName(robot)) {
    throw std::invalid_argument("robot name '" + robot +
                                "' is not a ROS 2 namespace (letters, digits, '_', '/')");
  }
}

}  // namespace

std::string robotTopic(const std::string& robot, const std::string& leaf) {
  checkRobot(robot);
  const bool absolute = !leaf.empty() && leaf.front() == '/';
  const std::string name = absolute ? leaf.substr(1) : leaf;
  if (name.empty() || !validRobotName(name))
    throw std::invalid_argument("topic name '" + leaf +
                                "' is not a ROS 2 name (letters, digits, '_', '/')");
  if (absolute) return leaf;
  return robot.empty() ? "/" + leaf : "/" + robot + "/" + leaf;
}

std::optional<std::string> robotOfTopic(const std::string& topic, const std::string& leaf) {
  if (leaf.empty()) return std::nullopt;
  if (leaf.front() == '/') return topic == leaf ? std::optional<std::string>("") : std::nullopt;
  const std::string tail = "/" + leaf;
  if (topic.size() < tail.size() ||
      topic.compare(topic.size() - tail.size(), tail.size(), tail) != 0)
    return std::nullopt;
  const std::string robot = topic.substr(0, topic.size() - tail.size());
  if (robot.empty()) return std::string();
  if (robot.front() != '/' || !validRobotName(robot.substr(1))) return std::nullopt;
  return robot.substr(1);
}

std::string robotFrame(const std::string& robot, const std::string& frame) {
  checkRobot(robot);
  return robot.empty() ? frame : robot + "/" + frame;
}

std::vector<std::string> robotBaseFrames(const std::string& robot,
                                         const std::string& odometry_frame) {
  std::vector<std::string> bases;
  auto add = [&](const std::string& frame) {
    if (!frame.empty() && std::find(bases.begin(), bases.end(), frame) == bases.end())
      bases.push_back(frame);
  };
  add(odometry_frame);
  for (const char* leaf : {"base_footprint", "base_link"}) add(robotFrame(robot, leaf));
  for (const char* leaf : {"base_footprint", "base_link"}) add(leaf);
  return bases;
}

SensorTopics readSensorTopics(const common::ConfigNode& node, const std::string& robot,
                              SensorTopics defaults, bool imu_and_pressure) {
  try {
    checkRobot(robot);
  } catch (const std::invalid_argument& e) {
    node.fail("robot", e.what());
  }
  auto read = [&](const char* key, std::string& value) {
    value = node.get<std::string>(key, value);
    try {
      robotTopic(robot, value);
    } catch (const std::invalid_argument& e) {
      node.fail(key, e.what());
    }
  };
  read("scan_topic", defaults.scan);
  read("odom_topic", defaults.odom);
  if (imu_and_pressure) {
    read("imu_topic", defaults.imu);
    read("pressure_topic", defaults.pressure);
  }
  return defaults;
}

}  // namespace storey::runtime
