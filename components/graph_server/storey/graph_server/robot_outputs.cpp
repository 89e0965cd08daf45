// GraphServer's live outputs per robot (see graph_server.h).
#include "storey/graph_server/conversions.h"
#include "storey/graph_server/graph_server.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::graph_server {

void GraphServer::publishRobotOutputs(const std::vector<building::RobotLocation>& locations,
                                      const std::map<int, nav_msgs::msg::OccupancyGrid>& maps) {
  if (locations.empty()) return;
  if (!tf_publisher_) {
    tf_publisher_ = createPublisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>(
        "/tf", runtime::TopicKind::kLatest);
  }
  tf2_msgs::msg::TFMessage tf;
  for (const auto& location : locations) {
    const std::string& robot = location.robot;
    // Stamped with the node's (sensor) time, so that it composes with the robot's own
    // odom -> base_link of that moment.
    auto odom = runtime::toTransform(location.odomInBuilding(), location.stamp, "building",
                                     runtime::robotFrame(robot, "odom"));
    odom.transform().translation().z(location.floor_height);
    tf.transforms().push_back(odom);

    RobotPublishers& p = robot_publishers_[robot];
    if (!p.pose) {
      p.pose = createPublisher<geometry_msgs::msg::PoseStamped,
                               geometry_msgs::msg::PoseStampedPubSubType>(
          runtime::robotTopic(robot, "pose"), runtime::TopicKind::kLatest);
      p.floor = createPublisher<std_msgs::msg::Int32, std_msgs::msg::Int32PubSubType>(
          runtime::robotTopic(robot, "floor"), runtime::TopicKind::kLatest);
      p.map = createPublisher<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>(
          runtime::robotTopic(robot, "map"), runtime::TopicKind::kLatest);
    }
    const auto at = runtime::toTransform(location.pose, location.stamp, "building", "");
    geometry_msgs::msg::PoseStamped pose;
    pose.header(at.header());
    pose.pose().position().x(location.pose.x());
    pose.pose().position().y(location.pose.y());
    pose.pose().position().z(location.floor_height);
    pose.pose().orientation(at.transform().rotation());
    p.pose->publish(pose);
    std_msgs::msg::Int32 floor;
    floor.data(location.floor_id);
    p.floor->publish(floor);
    const auto map = maps.find(location.floor_id);
    if (map != maps.end()) p.map->publish(map->second);
  }
  tf_publisher_->publish(tf);
}

}  // namespace storey::graph_server
