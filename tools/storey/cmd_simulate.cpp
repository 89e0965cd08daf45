// storey simulate SCENARIO.yaml --output DIR: runs the multistory building simulator and
// writes a rosbag2 bag of every robot's sensors, the ground truth and pictures of the
// true floors (format in docs/simulator.md).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>

#include "args.h"
#include "storey/common/log.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/sim/ground_truth.h"
#include "storey/sim/pictures.h"
#include "storey/sim/simulator.h"
#include "storey/tools/map_job.h"
#include "storey/tools/robot_setup.h"
#include "storey/tools/simulation_bag.h"

namespace storey::cli {

extern const char* const summary_simulate =
    "simulate robots in a multistory building: bag, ground truth, pictures";

namespace {

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) items.push_back(item);
  return items;
}

}  // namespace

int run_simulate(Args& args) {
  args.usage(
          "SCENARIO.yaml --output DIR",
          "Simulates the robots of a scenario (config/buildings/*.yaml) and writes into DIR:\n"
          "  bag/            rosbag2 (sqlite3) with /<robot>/scan, odom, pressure, imu\n"
          "  ground_truth/   trajectory.csv, floors.yaml, transits.csv, corridors.yaml\n"
          "  pictures/       floor_<id>.png, overlay_<a>_<b>.png, overlay_all.png\n"
          "  baseline_odometry/trajectory.csv   dead reckoning, for `storey evaluate`\n"
          "  scenario.yaml   a copy of the scenario file\n"
          "  live/           live.yaml, a bringup that maps the bag live as a deployment does\n"
          "                  (`storey launch DIR/live/live.yaml`, then `storey replay DIR/bag`),\n"
          "                  with the parameters `storey map` gives these robots\n"
          "The same scenario and seed give the same output.")
      .option("output", "DIR", "output folder (must not hold a bag already)")
      .option("seed", "N", "seed of every random choice", "1")
      .option("robot", "NAMES", "simulate only these robots (comma-separated)")
      .option("max-duration", "SECONDS", "stop each robot after this long (0: whole mission)", "0")
      .option("config", "DIR", "component parameter files for live/ (floor_detector.yaml, ...)",
              "the shipped config/")
      .flag("no-barometer", "the robots carry no barometer (no pressure topic)")
      .option("storage", "sqlite3|mcap", "the bag's storage (rosbag2's storage identifier)",
              "sqlite3")
      .flag("no-bag", "skip the bag (ground truth and pictures only)")
      .flag("no-pictures", "skip the pictures");
  if (!args.parse()) return 0;
  const std::string path = args.positional(0, "SCENARIO.yaml");
  if (args.positionals().size() > 1) throw UsageError("too many arguments (see --help)");
  if (!args.has("output")) throw UsageError("--output DIR is required");
  const std::string out = args.get("output");
  const long seed = args.getInt("seed");
  if (seed < 0) throw UsageError("--seed must not be negative");
  sim::SimulateOptions options;
  options.seed = static_cast<std::uint64_t>(seed);
  if (args.has("robot")) options.robots = splitList(args.get("robot"));
  options.max_duration = args.getDouble("max-duration");
  options.without_barometer = args.flagSet("no-barometer");
  if (options.max_duration < 0.0) throw UsageError("--max-duration must not be negative");

  namespace fs = std::filesystem;
  const auto started = std::chrono::steady_clock::now();
  const sim::Scenario scenario = sim::loadScenario(path);
  const sim::Simulation run = sim::simulate(scenario, options);
  const double simulated_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  fs::create_directories(out);
  const std::string storage = args.getChoice("storage", {bag::kStorageSqlite3, bag::kStorageMcap});
  if (!args.flagSet("no-bag"))
    tools::writeSimulationBag(run, (fs::path(out) / "bag").string(), storage);
  sim::writeGroundTruth(run, (fs::path(out) / "ground_truth").string());
  sim::writeOdometryBaseline(run, (fs::path(out) / "baseline_odometry").string());
  if (!args.flagSet("no-pictures"))
    sim::writePictures(run.building, (fs::path(out) / "pictures").string());
  fs::copy_file(path, fs::path(out) / "scenario.yaml", fs::copy_options::overwrite_existing);
  if (!args.flagSet("no-bag")) {
    std::vector<std::string> robots;
    for (const auto& robot : run.robots) robots.push_back(robot.name);
    const std::string config_dir = args.has("config") ? args.get("config") : tools::defaultConfigDir();
    tools::RobotSetup setup = tools::robotSetup(scenario);
    if (options.without_barometer) setup.without_barometer.insert(robots.begin(), robots.end());
    tools::writeLiveBringup(config_dir, robots, setup, (fs::path(out) / "live").string(),
                            (fs::path(out) / "bag").string());
  }

  std::size_t scans = 0;
  double robot_time = 0.0;
  for (const auto& robot : run.robots) {
    scans += robot.scans.size();
    if (!robot.truth.empty()) robot_time += robot.truth.back().stamp - robot.truth.front().stamp;
    std::printf("%s: %zu scans, %zu odometry, %zu pressure, %zu imu samples, %zu transits\n",
                robot.name.c_str(), robot.scans.size(), robot.odometry.size(),
                robot.pressure.size(), robot.imu.size(), robot.transits.size());
  }
  std::printf(
      "%s (seed %llu): %zu robots, %zu floors, %zu scans, %.1f s of robot time "
      "simulated in %.2f s; written to %s\n",
      scenario.name.c_str(), static_cast<unsigned long long>(options.seed), run.robots.size(),
      run.building.floors.size(), scans, robot_time, simulated_seconds, out.c_str());
  return 0;
}

}  // namespace storey::cli
