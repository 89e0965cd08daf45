// The simulator: plans every robot's mission, then samples its sensors along the true
// trajectory. Everything random comes from the seed, so the same scenario and seed give
// the same output byte for byte.
//
//   auto scenario = sim::loadScenario("config/buildings/small2.yaml");
//   sim::Simulation run = sim::simulate(scenario, 42);
//   for (const auto& scan : run.robots[0].scans) ...
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "storey/sensor/laser_scan.h"
#include "storey/sim/motion.h"
#include "storey/sim/scenario.h"

namespace storey::sim {

// The true state of a robot at one scan.
struct TruthSample {
  double stamp = 0.0;
  int floor = 0;         // index into Building::floors (the floor the robot counts as on)
  geometry::Pose2 pose;  // building frame
  double z = 0.0;        // height above the building origin
};

struct RobotRun {
  std::string name;
  // Each stream is ordered by stamp. Odometry starts at the identity in its own frame.
  std::vector<sensor::LaserScan> scans;
  std::vector<sensor::OdometrySample> odometry;
  std::vector<sensor::PressureSample> pressure;
  std::vector<sensor::ImuSample> imu;
  std::vector<TruthSample> truth;  // one per scan, same stamps
  std::vector<Transit> transits;
  Trajectory trajectory;
  std::size_t odometry_stalls = 0;  // times the odometry held still (OdometryOptions)
};

struct Simulation {
  std::string scenario;
  std::uint64_t seed = 0;
  Building building;
  double pressure_drift = 0.0;  // Pa/s, the weather during this run
  std::vector<RobotRun> robots;
};

struct SimulateOptions {
  std::uint64_t seed = 0;
  std::vector<std::string> robots;  // simulate only these ("" / empty: all)
  double max_duration = 0.0;        // stop each robot after this many seconds (0: whole mission)
  bool without_barometer = false;   // every robot as if it carried no barometer
};

Simulation simulate(const Scenario& scenario, const SimulateOptions& options);
inline Simulation simulate(const Scenario& scenario, std::uint64_t seed) {
  SimulateOptions options;
  options.seed = seed;
  return simulate(scenario, options);
}

// One scan from `pose` (building frame) against the given obstacles, without noise.
sensor::LaserScan castScan(const std::vector<Segment>& obstacles, const LaserOptions& laser,
                           const geometry::Pose2& pose);

}  // namespace storey::sim
