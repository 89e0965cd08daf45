// The main job, `storey map`: a recording (a bag, a CARMEN log, or a simulator scenario,
// simulated first) is replayed through all four components running in one process over
// DDS: floor_detector and floor_mapper per robot, one floor_matcher and one graph_server.
// When everything is processed the building is written to the output folder.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "storey/eval/metrics.h"
#include "storey/tools/building_report.h"

namespace storey::tools {

// One input. A floor recorded on its own (as in the paper, or by one robot of a fleet)
// gives its floor id and height, and then needs no floor detection.
struct MapInput {
  std::string path;
  std::optional<int> floor;
  std::optional<double> height;
  std::string robot;  // for CARMEN logs; "" -> "robot" or "floor<k>"
};

// A recorded fleet's floors, as the simulator gives them for a simulated one: the
// building's floor heights and where each robot starts. Every floor detector then knows
// the heights and its robot's start floor, and every mapper its start floor and height,
// so floor ids and heights agree across robots. From `storey map BAG --robots FILE`:
//   floor_heights: [0.0, 3.6, 7.2]     # metres, by floor index, increasing
//   robots:
//     robot1: {start_floor: 0}         # index into floor_heights
//     robot2: {start_floor: 2}
struct RobotFloors {
  std::vector<double> heights;
  std::map<std::string, int> start_floor;
  std::string path;  // the file, for messages
};
// Errors (common::ConfigError) name the file, line and key.
RobotFloors readRobotFloors(const std::string& yaml_path);

struct MapJobOptions {
  std::vector<MapInput> inputs;  // empty: the bundled simulated building
  std::optional<RobotFloors> robot_floors;  // recordings only: every recorded robot listed
  std::string output_dir = "out";
  std::uint64_t seed = 1;        // simulator and every component's random choices
  bool without_barometer = false;  // a simulated building's robots carry no barometer
  int domain_id = -1;            // -1: ROS_DOMAIN_ID, else 0
  std::string config_dir;        // component parameter files; "" -> the shipped config/
  BuildingOutputOptions outputs;
  double flush_timeout = 600.0;  // seconds allowed per component to finish its work
  bool quiet = false;
  bool keep_graph = false;  // return the final building graph (MapJobResult::graph)
};

struct MapJobResult {
  std::string output_dir;
  std::string scenario;  // when a simulated building was mapped
  BuildingOutputSummary outputs;
  std::optional<eval::Evaluation> evaluation;            // when ground truth is known
  std::optional<eval::Evaluation> evaluation_unaligned;  // the same without inter-floor constraints
  std::vector<Timing> timings;
  std::string ground_truth_dir;  // when a simulated building was mapped
  // The final building graph (floor graphs and inter-floor constraints), with keep_graph.
  std::shared_ptr<const building::BuildingGraph> graph;
  double recording_seconds = 0.0;
  double total_seconds = 0.0;
};

// The shipped configuration folder (source tree, else the installed copy).
std::string defaultConfigDir();
// The bundled simulated building of `storey map` with no input.
std::string defaultBuilding(const std::string& config_dir);

// Parses "PATH", "PATH@FLOOR" or "PATH@FLOOR:HEIGHT" (floor recorded on its own).
MapInput parseMapInput(const std::string& text);
// A YAML list of inputs: `floors: [{path: a.log, floor: 0, height: 0.0}, ...]`; paths are
// relative to the file. Errors name the file, key and line.
std::vector<MapInput> readMapInputs(const std::string& yaml_path);

MapJobResult runMapJob(const MapJobOptions& options);

}  // namespace storey::tools
