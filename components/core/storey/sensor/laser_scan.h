// A planar laser scan in the ROS LaserScan convention: beam i points at
// angle_min + i * angle_increment in the sensor frame. A range that is NaN, infinite,
// below range_min or at/beyond range_max is "no return": never an obstacle.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "storey/geometry/pose2.h"

namespace storey::sensor {

struct LaserScan {
  double stamp = 0.0;  // seconds
  double angle_min = 0.0;
  double angle_increment = 0.0;
  double range_min = 0.0;
  double range_max = 0.0;
  std::vector<float> ranges;
  geometry::Pose2 sensor_offset;  // sensor pose in the robot frame

  std::size_t size() const { return ranges.size(); }
  double angle(std::size_t i) const { return angle_min + static_cast<double>(i) * angle_increment; }
  bool isReturn(std::size_t i) const;
  std::size_t countReturns() const;
  // Unit vectors (cos, sin) of every beam's angle in the sensor frame. Scans of one sensor
  // share them: the last geometry asked for on this thread is kept, so a log's scans
  // compute them once instead of a sine and cosine per beam per use.
  std::shared_ptr<const std::vector<Eigen::Vector2d>> beamDirections() const;
  // Endpoints of valid returns in the robot frame (sensor offset applied).
  std::vector<Eigen::Vector2d> pointsInRobotFrame() const;
  // Endpoints of valid returns in the world, for a robot at `robot_pose`.
  std::vector<Eigen::Vector2d> pointsInWorld(const geometry::Pose2& robot_pose) const;
  // "" when the scan is usable, else why not (size mismatch, bad limits, no beams...).
  std::string validate() const;
};

// A subsampled copy keeping every `step`-th beam (for fast sensor models).
LaserScan subsample(const LaserScan& scan, std::size_t step);

struct OdometrySample {
  double stamp = 0.0;
  geometry::Pose2 pose;  // in the odometry frame
  double linear_velocity = 0.0;
  double angular_velocity = 0.0;
  double z = 0.0;  // vertical position when the odometry has one (else 0)
};

struct PressureSample {
  double stamp = 0.0;
  double pascal = 0.0;
  double variance = 0.0;  // 0 when unknown
};

struct ImuSample {
  double stamp = 0.0;
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  // m/s^2, includes gravity
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
};

// The sample in the frame the IMU is mounted on, given the IMU frame's yaw there (rad):
// both vectors turned about z.
inline ImuSample rotatedByYaw(ImuSample sample, double yaw) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  sample.linear_acceleration = r * sample.linear_acceleration;
  sample.angular_velocity = r * sample.angular_velocity;
  return sample;
}

}  // namespace storey::sensor
