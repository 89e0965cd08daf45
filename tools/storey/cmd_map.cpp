// storey map [INPUT...]: the main job. See storey/tools/map_job.h.
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "args.h"
#include "storey/eval/metrics.h"
#include "storey/tools/map_job.h"

namespace storey::cli {

extern const char* const summary_map = "map a building from a recording or a simulated building (the main job)";

int run_map(Args& args) {
  args.usage(
          "[INPUT...] [--output DIR]",
          "Maps a building. INPUT is a simulator building file (config/buildings/*.yaml: it is\n"
          "simulated first), a rosbag2 bag, or a CARMEN log; with no INPUT the bundled simulated\n"
          "building is mapped. Floors recorded separately are given one per input as\n"
          "PATH@FLOOR or PATH@FLOOR:HEIGHT, or listed in a file with --floors FILE.yaml.\n"
          "The recording is replayed through floor_detector, floor_mapper, floor_matcher and\n"
          "graph_server in this process over DDS, on a participant that discovers no other and\n"
          "that no other discovers (a replay or robot on the same domain cannot disturb it).\n"
          "The building is written to DIR: floor_<id>.pgm/.yaml/.png (building frame),\n"
          "building.yaml, graph.g2o, trajectory.csv, building.bt, report.html, journal.bin (and\n"
          "recording/ for a simulated building).")
      .option("output", "DIR", "output folder", "out/<input name>")
      .option("floors", "FILE", "YAML list of per-floor inputs: floors: [{path, floor, height}]")
      .option(
          "robots", "FILE",
          "a recorded fleet's floors: floor_heights: [...] and robots: {NAME: {start_floor: K}}")
      .option("seed", "N", "seed of the simulator and of every random choice", "1")
      .option("config", "DIR", "component parameter files (floor_detector.yaml, ...)",
              "the shipped config/")
      .option("domain", "ID",
              "DDS domain id of the job's private participant (default: ROS_DOMAIN_ID, else 0)",
              "-1")
      .flag("no-barometer",
            "a simulated building's robots carry no barometer (floor changes from the IMU)")
      .option("resolution", "M", "resolution of the floor maps", "0.05")
      .option("voxel", "M", "OctoMap resolution", "0.1")
      .flag("quiet", "print only the summary");
  if (!args.parse()) return 0;
  tools::MapJobOptions options;
  for (const auto& text : args.positionals()) options.inputs.push_back(tools::parseMapInput(text));
  if (args.has("floors")) {
    if (!options.inputs.empty()) throw UsageError("give inputs either as arguments or with --floors, not both");
    options.inputs = tools::readMapInputs(args.get("floors"));
  }
  if (args.has("robots")) options.robot_floors = tools::readRobotFloors(args.get("robots"));
  const long seed = args.getInt("seed");
  if (seed < 0) throw UsageError("--seed must not be negative");
  options.seed = static_cast<std::uint64_t>(seed);
  options.domain_id = static_cast<int>(args.getInt("domain"));
  if (args.has("config")) options.config_dir = args.get("config");
  options.outputs.map.resolution =
      args.getDouble("resolution", tools::kMapResolutionRange[0], tools::kMapResolutionRange[1]);
  options.outputs.octomap.resolution =
      args.getDouble("voxel", tools::kVoxelRange[0], tools::kVoxelRange[1]);
  options.quiet = args.flagSet("quiet");
  options.without_barometer = args.flagSet("no-barometer");
  if (args.has("output")) {
    options.output_dir = args.get("output");
  } else {
    std::string name = options.inputs.empty() ? tools::defaultBuilding(tools::defaultConfigDir())
                                              : options.inputs.front().path;
    name = std::filesystem::path(name).filename().string();
    for (const char* ext : {".gz", ".yaml", ".log", ".gfs", ".db3"}) {
      const std::string e = ext;
      if (name.size() > e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0)
        name.resize(name.size() - e.size());
    }
    options.output_dir = "out/" + name;
  }
  const tools::MapJobResult result = tools::runMapJob(options);
  std::cout << std::setprecision(4) << "building written to " << result.output_dir << ": "
            << result.outputs.floors << " floors, " << result.outputs.constraints << " inter-floor constraints, "
            << result.outputs.occupied_voxels << " occupied voxels\n";
  for (const auto& t : result.timings) std::cout << "  " << t.phase << ": " << t.seconds << " s\n";
  std::cout << "  total: " << result.total_seconds << " s";
  if (result.recording_seconds > 0)
    std::cout << " for " << result.recording_seconds << " s of recording (" << result.recording_seconds / result.total_seconds
              << "x real time)";
  std::cout << "\n";
  if (result.evaluation_unaligned) {
    std::cout << "\nwithout inter-floor constraints:\n" << eval::toTable(*result.evaluation_unaligned);
  }
  if (result.evaluation) {
    std::cout << "\nwith inter-floor constraints:\n" << eval::toTable(*result.evaluation);
  }
  std::cout << "\nreport: " << result.output_dir << "/report.html\n";
  return 0;
}

}  // namespace storey::cli
