// How each robot of a building is mapped, shared by `storey map` (which runs the
// components itself) and `storey simulate` (which writes a bringup to run them live):
// a simulated robot's laser model (its range noise, which the floor_mapper's noise floors
// follow), and a fleet's floor heights and start floors, so that every robot numbers floors
// the same way.
#pragma once

#include <yaml-cpp/yaml.h>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "storey/runtime/sensor_topics.h"
#include "storey/sim/scenario.h"

namespace storey::tools {

struct RobotSetup {
  // A simulated robot's laser range noise (m), by robot name: the floor_mapper's laser model.
  std::map<std::string, double> laser_range_noise;
  // A fleet: the building's floor heights (by index) and each robot's start floor index.
  // Empty for one robot, whose detector numbers floors from where it starts.
  std::vector<double> floor_heights;
  std::map<std::string, int> start_floor;
  // Robots recorded on one floor (`storey map PATH@FLOOR:HEIGHT`): floor id and height.
  // Their mapper starts on that floor and has no floor detector to wait for.
  struct RecordedFloor {
    int floor = 0;
    double height = 0.0;
  };
  std::map<std::string, RecordedFloor> recorded_floor;
  // Robots that carry no barometer: their floor_detector takes heights from the IMU.
  std::set<std::string> without_barometer;
};

// What a simulated building's robots are mapped with.
RobotSetup robotSetup(const sim::Scenario& scenario);

// The parameters of a robot's floor_detector and floor_mapper: the file `kind`.yaml of
// `config_dir` (an empty mapping if it has none) with the robot's name and setup laid
// over it.
YAML::Node floorDetectorParameters(const std::string& config_dir, const std::string& robot, const RobotSetup& setup);
YAML::Node floorMapperParameters(const std::string& config_dir, const std::string& robot, const RobotSetup& setup);
// `config_dir`/`kind`.yaml (its path, and its contents or an empty mapping).
std::string parameterFilePath(const std::string& config_dir, const std::string& kind);
YAML::Node parameterFile(const std::string& config_dir, const std::string& kind);
// The robots' sensor topic names: scan_topic and odom_topic of floor_mapper.yaml, which
// floor_detector.yaml must name alike (else std::invalid_argument naming both files), and
// imu_topic and pressure_topic of floor_detector.yaml.
runtime::SensorTopics sensorTopics(const std::string& config_dir);

// `storey simulate`: writes into `dir` a bringup file, live.yaml, that runs the
// simulated robots' components as `storey map` runs them (floor_detector and floor_mapper
// per robot, with their setup, one floor_matcher and one graph_server journaling to
// `dir`/journal.bin), in one process, matching while the graphs grow as a deployment
// does, and one parameter file per component beside it; its comments say how to feed it
// `bag`. Returns the bringup file's path.
std::string writeLiveBringup(const std::string& config_dir, const std::vector<std::string>& robots,
                             const RobotSetup& setup, const std::string& dir, const std::string& bag);

}  // namespace storey::tools
