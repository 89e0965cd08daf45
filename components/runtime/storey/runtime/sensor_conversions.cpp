#include "storey/runtime/sensor_conversions.h"

#include <cmath>
#include <stdexcept>

#include "storey/common/log.h"

namespace storey::runtime {
namespace {

constexpr std::int64_t kNsPerSecond = 1'000'000'000;

void setStamp(std_msgs::msg::Header& header, double stamp, const std::string& frame_id) {
  header.stamp(toTimeMessage(stamp));
  header.frame_id(frame_id);
}

}  // namespace

std::int64_t stampToNanoseconds(double stamp) {
  if (!std::isfinite(stamp) || std::fabs(stamp) > 9.2e9) {
    throw std::invalid_argument("stamp " + std::to_string(stamp) + " s is not a valid time");
  }
  // Split first so the fraction keeps its precision for large stamps.
  const double seconds = std::floor(stamp);
  return static_cast<std::int64_t>(seconds) * kNsPerSecond + std::llround((stamp - seconds) * 1e9);
}

double nanosecondsToStamp(std::int64_t ns) {
  std::int64_t seconds = ns / kNsPerSecond;
  std::int64_t rest = ns % kNsPerSecond;
  if (rest < 0) {
    rest += kNsPerSecond;
    --seconds;
  }
  return static_cast<double>(seconds) + static_cast<double>(rest) * 1e-9;
}

builtin_interfaces::msg::Time nanosecondsToTimeMessage(std::int64_t ns) {
  std::int64_t seconds = ns / kNsPerSecond;
  std::int64_t rest = ns % kNsPerSecond;
  if (rest < 0) {
    rest += kNsPerSecond;
    --seconds;
  }
  builtin_interfaces::msg::Time time;
  time.sec(static_cast<std::int32_t>(seconds));
  time.nanosec(static_cast<std::uint32_t>(rest));
  return time;
}

builtin_interfaces::msg::Time toTimeMessage(double stamp) {
  return nanosecondsToTimeMessage(stampToNanoseconds(stamp));
}

std::int64_t timeMessageToNanoseconds(const builtin_interfaces::msg::Time& time) {
  return static_cast<std::int64_t>(time.sec()) * kNsPerSecond +
         static_cast<std::int64_t>(time.nanosec());
}

double fromTimeMessage(const builtin_interfaces::msg::Time& time) {
  return static_cast<double>(time.sec()) + static_cast<double>(time.nanosec()) * 1e-9;
}

geometry_msgs::msg::Quaternion yawToQuaternion(double yaw) {
  geometry_msgs::msg::Quaternion q;
  q.x(0.0);
  q.y(0.0);
  q.z(std::sin(0.5 * yaw));
  q.w(std::cos(0.5 * yaw));
  return q;
}

double quaternionToYaw(const geometry_msgs::msg::Quaternion& q) {
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()),
                    1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}

sensor_msgs::msg::LaserScan toMessage(const sensor::LaserScan& scan, const std::string& frame_id) {
  sensor_msgs::msg::LaserScan msg;
  setStamp(msg.header(), scan.stamp, frame_id);
  const double span = scan.ranges.empty()
                          ? 0.0
                          : static_cast<double>(scan.ranges.size() - 1) * scan.angle_increment;
  msg.angle_min(static_cast<float>(scan.angle_min));
  msg.angle_max(static_cast<float>(scan.angle_min + span));
  msg.angle_increment(static_cast<float>(scan.angle_increment));
  msg.time_increment(0.0f);
  msg.scan_time(0.0f);
  msg.range_min(static_cast<float>(scan.range_min));
  msg.range_max(static_cast<float>(scan.range_max));
  msg.ranges(scan.ranges);
  return msg;
}

sensor::LaserScan fromMessage(const sensor_msgs::msg::LaserScan& msg,
                              const geometry::Pose2& sensor_offset) {
  sensor::LaserScan scan;
  scan.stamp = fromTimeMessage(msg.header().stamp());
  scan.angle_min = msg.angle_min();
  scan.angle_increment = msg.angle_increment();
  scan.range_min = msg.range_min();
  scan.range_max = msg.range_max();
  scan.ranges = msg.ranges();
  scan.sensor_offset = sensor_offset;
  return scan;
}

nav_msgs::msg::Odometry toMessage(const sensor::OdometrySample& odom, const std::string& frame_id,
                                  const std::string& child_frame_id) {
  nav_msgs::msg::Odometry msg;
  setStamp(msg.header(), odom.stamp, frame_id);
  msg.child_frame_id(child_frame_id);
  geometry_msgs::msg::Pose& pose = msg.pose().pose();
  pose.position().x(odom.pose.x());
  pose.position().y(odom.pose.y());
  pose.position().z(odom.z);
  pose.orientation(yawToQuaternion(odom.pose.theta()));
  msg.twist().twist().linear().x(odom.linear_velocity);
  msg.twist().twist().angular().z(odom.angular_velocity);
  return msg;
}

sensor::OdometrySample fromMessage(const nav_msgs::msg::Odometry& msg) {
  sensor::OdometrySample odom;
  odom.stamp = fromTimeMessage(msg.header().stamp());
  const geometry_msgs::msg::Pose& pose = msg.pose().pose();
  odom.pose = geometry::Pose2(pose.position().x(), pose.position().y(),
                              quaternionToYaw(pose.orientation()));
  odom.z = pose.position().z();
  odom.linear_velocity = msg.twist().twist().linear().x();
  odom.angular_velocity = msg.twist().twist().angular().z();
  return odom;
}

sensor_msgs::msg::FluidPressure toMessage(const sensor::PressureSample& pressure,
                                          const std::string& frame_id) {
  sensor_msgs::msg::FluidPressure msg;
  setStamp(msg.header(), pressure.stamp, frame_id);
  msg.fluid_pressure(pressure.pascal);
  msg.variance(pressure.variance);
  return msg;
}

sensor::PressureSample fromMessage(const sensor_msgs::msg::FluidPressure& msg) {
  sensor::PressureSample pressure;
  pressure.stamp = fromTimeMessage(msg.header().stamp());
  pressure.pascal = msg.fluid_pressure();
  pressure.variance = msg.variance();
  return pressure;
}

sensor_msgs::msg::Imu toMessage(const sensor::ImuSample& imu, const std::string& frame_id) {
  sensor_msgs::msg::Imu msg;
  setStamp(msg.header(), imu.stamp, frame_id);
  msg.orientation().w(1.0);
  msg.orientation_covariance().fill(0.0);
  msg.orientation_covariance()[0] = -1.0;
  msg.angular_velocity().x(imu.angular_velocity.x());
  msg.angular_velocity().y(imu.angular_velocity.y());
  msg.angular_velocity().z(imu.angular_velocity.z());
  msg.linear_acceleration().x(imu.linear_acceleration.x());
  msg.linear_acceleration().y(imu.linear_acceleration.y());
  msg.linear_acceleration().z(imu.linear_acceleration.z());
  return msg;
}

sensor::ImuSample fromMessage(const sensor_msgs::msg::Imu& msg) {
  sensor::ImuSample imu;
  imu.stamp = fromTimeMessage(msg.header().stamp());
  imu.angular_velocity = {msg.angular_velocity().x(), msg.angular_velocity().y(),
                          msg.angular_velocity().z()};
  imu.linear_acceleration = {msg.linear_acceleration().x(), msg.linear_acceleration().y(),
                             msg.linear_acceleration().z()};
  return imu;
}

geometry_msgs::msg::TransformStamped toTransform(const geometry::Pose2& pose, double stamp,
                                                 const std::string& parent_frame,
                                                 const std::string& child_frame) {
  geometry_msgs::msg::TransformStamped msg;
  setStamp(msg.header(), stamp, parent_frame);
  msg.child_frame_id(child_frame);
  msg.transform().translation().x(pose.x());
  msg.transform().translation().y(pose.y());
  msg.transform().translation().z(0.0);
  msg.transform().rotation(yawToQuaternion(pose.theta()));
  return msg;
}

geometry::Pose2 fromTransform(const geometry_msgs::msg::TransformStamped& transform) {
  const auto& t = transform.transform();
  return geometry::Pose2(t.translation().x(), t.translation().y(), quaternionToYaw(t.rotation()));
}

void addStaticTransforms(const tf2_msgs::msg::TFMessage& message, geometry::FrameTree* frames,
                         const std::string& who) {
  for (const auto& t : message.transforms()) {
    try {
      frames->set(t.header().frame_id(), t.child_frame_id(), fromTransform(t));
    } catch (const std::invalid_argument& e) {
      common::logWarn(who + ": ignoring a tf_static transform: " + e.what());
    }
  }
}

}  // namespace storey::runtime
