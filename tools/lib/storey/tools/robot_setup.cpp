#include "storey/tools/robot_setup.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "storey/common/config.h"

namespace storey::tools {

namespace fs = std::filesystem;

RobotSetup robotSetup(const sim::Scenario& scenario) {
  RobotSetup setup;
  for (const auto& robot : scenario.robots) {
    setup.laser_range_noise[robot.name] = robot.model.laser.range_sigma;
    if (!robot.model.barometer.present) setup.without_barometer.insert(robot.name);
  }
  if (scenario.robots.size() > 1) {
    for (const auto& f : scenario.building.floors) setup.floor_heights.push_back(f.height);  // by height
    for (const auto& robot : scenario.robots)
      setup.start_floor[robot.name] = scenario.building.floorIndex(robot.start_floor);
  }
  return setup;
}

std::string parameterFilePath(const std::string& config_dir, const std::string& kind) {
  return (fs::path(config_dir) / (kind + ".yaml")).string();
}

YAML::Node parameterFile(const std::string& config_dir, const std::string& kind) {
  const std::string path = parameterFilePath(config_dir, kind);
  if (!fs::exists(path)) return YAML::Node(YAML::NodeType::Map);
  return YAML::Clone(common::ConfigNode::loadFile(path).yaml());
}

runtime::SensorTopics sensorTopics(const std::string& config_dir) {
  const std::string detector_file = parameterFilePath(config_dir, "floor_detector");
  const std::string mapper_file = parameterFilePath(config_dir, "floor_mapper");
  runtime::SensorTopics topics = runtime::readSensorTopics(
      common::ConfigNode(parameterFile(config_dir, "floor_detector"), detector_file, ""), "", {},
      true);
  const runtime::SensorTopics mapped = runtime::readSensorTopics(
      common::ConfigNode(parameterFile(config_dir, "floor_mapper"), mapper_file, ""), "", {},
      false);
  if (mapped.scan != topics.scan || mapped.odom != topics.odom)
    throw std::invalid_argument(mapper_file + ": scan_topic '" + mapped.scan +
                                "' and odom_topic '" + mapped.odom + "' differ from " +
                                detector_file + "'s '" + topics.scan + "' and '" + topics.odom +
                                "' (a robot's components read the same topics)");
  return topics;
}

YAML::Node floorDetectorParameters(const std::string& config_dir, const std::string& robot, const RobotSetup& setup) {
  YAML::Node n = parameterFile(config_dir, "floor_detector");
  n["robot"] = robot;
  if (setup.without_barometer.count(robot)) n["detector"]["sensors"]["barometer"] = false;
  const auto start = setup.start_floor.find(robot);
  if (start != setup.start_floor.end()) {
    YAML::Node floors = n["detector"]["floors"];
    floors["heights"] = setup.floor_heights;
    floors["initial_floor"] = start->second;
  }
  return n;
}

YAML::Node floorMapperParameters(const std::string& config_dir, const std::string& robot, const RobotSetup& setup) {
  YAML::Node n = parameterFile(config_dir, "floor_mapper");
  const auto laser = setup.laser_range_noise.find(robot);
  if (laser != setup.laser_range_noise.end()) n["slam"]["laser"]["range_noise"] = laser->second;
  n["robot"] = robot;
  const auto start = setup.start_floor.find(robot);
  if (start != setup.start_floor.end()) {
    n["initial_floor"] = start->second;
    n["initial_height"] = setup.floor_heights.at(static_cast<std::size_t>(start->second));
  }
  const auto recorded = setup.recorded_floor.find(robot);
  if (recorded != setup.recorded_floor.end()) {
    n["initial_floor"] = recorded->second.floor;
    n["initial_height"] = recorded->second.height;
    n["wait_for_floor_detector"] = false;
  }
  return n;
}

namespace {

void writeYaml(const fs::path& path, const std::string& header, const YAML::Node& node) {
  std::ofstream out(path);
  YAML::Emitter emitter;
  emitter << node;
  out << header << emitter.c_str() << "\n";
  if (!out) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace

std::string writeLiveBringup(const std::string& config_dir, const std::vector<std::string>& robots,
                             const RobotSetup& setup, const std::string& dir, const std::string& bag) {
  fs::create_directories(dir);
  const fs::path root = fs::absolute(dir);
  const std::string made = "# Written by `storey simulate` from " + fs::absolute(config_dir).string() + "/";
  YAML::Node components(YAML::NodeType::Sequence);
  auto add = [&](const std::string& kind, const std::string& name, const YAML::Node& parameters,
                 const std::string& why) {
    const std::string file = name + ".yaml";
    writeYaml(root / file, made + kind + ".yaml" + why + "\n", parameters);
    YAML::Node c;
    c["kind"] = kind;
    c["name"] = name;
    c["parameters"] = file;
    components.push_back(c);
  };
  for (const auto& robot : robots) {
    const bool fleet = setup.start_floor.count(robot) > 0;
    add("floor_detector", "floor_detector_" + robot,
        floorDetectorParameters(config_dir, robot, setup),
        fleet ? ", with the building's floor heights and this robot's start floor" : "");
    add("floor_mapper", "floor_mapper_" + robot, floorMapperParameters(config_dir, robot, setup),
        setup.laser_range_noise.count(robot) ? ", with the simulated laser's range noise" : "");
  }
  add("floor_matcher", "floor_matcher", parameterFile(config_dir, "floor_matcher"), "");
  YAML::Node server = parameterFile(config_dir, "graph_server");
  server["journal"] = (root / "journal.bin").string();
  add("graph_server", "graph_server", server, ", journaling to this folder");

  YAML::Node process;
  process["name"] = "storey";
  process["components"] = components;
  YAML::Node bringup;
  bringup["processes"].push_back(process);
  const fs::path file = root / "live.yaml";
  writeYaml(file,
            "# The simulated robots' components as a deployment runs them, matching while the graphs\n"
            "# grow. Run it, feed it the bag, then export the journal:\n"
            "#   storey launch " + file.string() + "\n"
            "#   storey replay " + fs::absolute(bag).string() + " --rate 1   # in another terminal\n"
            "#   storey export " + (root / "journal.bin").string() + " OUT\n",
            bringup);
  return file.string();
}

}  // namespace storey::tools
