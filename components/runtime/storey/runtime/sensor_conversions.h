// Core sensor types <-> ROS 2 messages, converted once at the component boundary.
// Stamps: core uses double seconds, ROS 2 builtin_interfaces/Time (sec, nanosec), bags
// int64 nanoseconds. The laser's mounting (sensor_offset) is not part of
// sensor_msgs/LaserScan; ROS 2 carries it in /tf_static, see toTransform/fromTransform.
#pragma once

#include <cstdint>
#include <string>

#include "builtin_interfaces/msg/Time.h"
#include "geometry_msgs/msg/Quaternion.h"
#include "geometry_msgs/msg/TransformStamped.h"
#include "nav_msgs/msg/Odometry.h"
#include "sensor_msgs/msg/FluidPressure.h"
#include "sensor_msgs/msg/Imu.h"
#include "sensor_msgs/msg/LaserScan.h"
#include "storey/geometry/frame_tree.h"
#include "storey/geometry/pose2.h"
#include "storey/sensor/laser_scan.h"
#include "tf2_msgs/msg/TFMessage.h"

namespace storey::runtime {

// Nearest nanosecond (std::invalid_argument for a non-finite stamp); exact for stamps read back
// from nanoseconds to ~0.1 us at 2e9 s.
std::int64_t stampToNanoseconds(double stamp);
double nanosecondsToStamp(std::int64_t ns);
builtin_interfaces::msg::Time toTimeMessage(double stamp);
builtin_interfaces::msg::Time nanosecondsToTimeMessage(std::int64_t ns);
double fromTimeMessage(const builtin_interfaces::msg::Time& time);
std::int64_t timeMessageToNanoseconds(const builtin_interfaces::msg::Time& time);

// Planar heading <-> quaternion about z (roll and pitch are dropped when reading).
geometry_msgs::msg::Quaternion yawToQuaternion(double yaw);
double quaternionToYaw(const geometry_msgs::msg::Quaternion& q);

// angle_max = angle_min + (n - 1) * increment; time_increment and scan_time are 0 and
// intensities empty. The message's float fields round the doubles to float precision.
sensor_msgs::msg::LaserScan toMessage(const sensor::LaserScan& scan,
                                      const std::string& frame_id = "laser");
// The sensor offset comes from elsewhere (tf); identity unless given.
sensor::LaserScan fromMessage(const sensor_msgs::msg::LaserScan& msg,
                              const geometry::Pose2& sensor_offset = geometry::Pose2());

// Pose in header.frame_id, velocities in child_frame_id (twist.linear.x, twist.angular.z),
// position.z = sample.z.
nav_msgs::msg::Odometry toMessage(const sensor::OdometrySample& odom,
                                  const std::string& frame_id = "odom",
                                  const std::string& child_frame_id = "base_link");
sensor::OdometrySample fromMessage(const nav_msgs::msg::Odometry& msg);

sensor_msgs::msg::FluidPressure toMessage(const sensor::PressureSample& pressure,
                                          const std::string& frame_id = "base_link");
sensor::PressureSample fromMessage(const sensor_msgs::msg::FluidPressure& msg);

// The orientation is marked unknown (orientation_covariance[0] = -1, the ROS convention).
sensor_msgs::msg::Imu toMessage(const sensor::ImuSample& imu, const std::string& frame_id = "imu");
sensor::ImuSample fromMessage(const sensor_msgs::msg::Imu& msg);

// A planar transform child -> parent (e.g. base_link -> laser) as a TransformStamped.
geometry_msgs::msg::TransformStamped toTransform(const geometry::Pose2& pose, double stamp,
                                                 const std::string& parent_frame,
                                                 const std::string& child_frame);
geometry::Pose2 fromTransform(const geometry_msgs::msg::TransformStamped& transform);
// Adds every transform of a tf_static message to `frames`; one that cannot be (a frame
// its own parent, a cycle) is skipped with a warning naming `who`.
void addStaticTransforms(const tf2_msgs::msg::TFMessage& message, geometry::FrameTree* frames,
                         const std::string& who);

}  // namespace storey::runtime
