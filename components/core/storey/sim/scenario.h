// A simulation scenario: a building, the robots (sensor and motion models) and their
// missions. One YAML file holds it (config/buildings/<name>.yaml); robot models live in
// config/robots/<model>.yaml and are referenced by name. See docs/simulator.md.
#pragma once

#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/geometry/pose2.h"
#include "storey/sim/building.h"

namespace storey::sim {

struct LaserOptions {
  double rate = 5.0;              // Hz
  double fov = 4.71238898038469;  // radians, centred on the sensor's x axis
  int beams = 271;
  double min_range = 0.1;
  double max_range = 30.0;
  double range_sigma = 0.01;  // m
  double dropout = 0.0;       // probability that a beam returns nothing
  geometry::Pose2 offset;     // sensor in the robot frame
};

struct OdometryOptions {
  double rate = 20.0;
  // Variances grow with the motion: after d metres driven the translation error has
  // sigma translation_sigma * sqrt(d), and so on, whatever the odometry rate.
  double translation_sigma = 0.02;         // m per sqrt(m) driven
  double rotation_sigma = 0.02;            // rad per sqrt(rad) turned
  double rotation_per_metre_sigma = 0.01;  // rad per sqrt(m) driven
  double elevator_heading_sigma = 0.0;     // extra heading error per elevator ride, rad
  // Stalls: now and then the published pose holds still for stall_duration while the robot
  // moves, then catches up at once (a driver or bus that lags). Starts are exponentially
  // distributed with this mean; 0: none.
  double stall_interval = 0.0;  // s
  double stall_duration = 0.5;  // s
};

struct BarometerOptions {
  bool present = true;  // false: the robot carries none (no pressure samples)
  double rate = 10.0;
  double sigma = 3.0;  // Pa
};

struct ImuOptions {
  double rate = 50.0;
  double accel_sigma = 0.05;  // m/s^2, white noise per sample
  double gyro_sigma = 0.005;  // rad/s
  // Accelerometer bias per axis: a first-order Gauss-Markov process (a MEMS part's bias
  // instability) with this standard deviation and correlation time.
  double accel_bias_sigma = 0.0;   // m/s^2
  double accel_bias_time = 300.0;  // s
  // Bumps on stairs: a vertical and forward oscillation of this amplitude, once a step.
  double stairs_vibration = 0.0;  // m/s^2
  // An elevator door that stops opening or closing shakes the floor: a vertical 10 Hz
  // oscillation of this amplitude, damped over 0.1 s.
  double door_jolt = 0.0;  // m/s^2
};

struct MotionOptions {
  double speed = 0.6;                 // m/s on floors
  double acceleration = 0.5;          // m/s^2
  double turn_rate = 1.0;             // rad/s
  double angular_acceleration = 2.0;  // rad/s^2
  double stairs_speed = 0.25;         // m/s along the stairs
  double elevator_speed = 1.0;        // m/s
  double elevator_acceleration = 0.5;
  double door_time = 2.0;  // s for a door to open or close
  double radius = 0.25;    // clearance kept from every obstacle, m
};

struct RobotModel {
  std::string name;
  LaserOptions laser;
  OdometryOptions odometry;
  BarometerOptions barometer;
  ImuOptions imu;
  MotionOptions motion;
};

RobotModel readRobotModel(const common::ConfigNode& node);

struct MissionStep {
  enum class Kind { kGo, kWait, kElevator, kStairs };
  Kind kind = Kind::kGo;
  Eigen::Vector2d target = Eigen::Vector2d::Zero();  // kGo: floor frame of the current floor
  double rise = 0.0;  // kGo: height climbed on the way (a ramp within the floor), m
  double seconds = 0.0;                              // kWait
  std::string shaft;                                 // kElevator, kStairs
  std::string to_floor;                              // kElevator, kStairs
  Origin origin;
};

struct RobotSpec {
  std::string name;
  RobotModel model;
  std::string start_floor;
  geometry::Pose2 start_pose;  // floor frame of the start floor
  double start_time = 0.0;     // s
  std::vector<MissionStep> mission;
  Origin origin;
};

struct Scenario {
  std::string name;
  std::string path;  // file it was read from ("" when built in code)
  Building building;
  std::vector<RobotSpec> robots;
};

// Reads and validates a scenario file: building geometry, robot models (a `model: name`
// is read from <dir of file>/../robots/<name>.yaml) and missions (checked for collisions
// by planning them). Throws common::ConfigError naming file, key and line.
Scenario loadScenario(const std::string& path);
// The same from text; robot models must then be given inline (`model: {...}`) unless
// `robots_dir` names the folder holding them.
Scenario loadScenarioString(const std::string& text, const std::string& name,
                            const std::string& robots_dir = "");

}  // namespace storey::sim
