// storey floors BAG: the floor changes in a recording, per robot, and with the simulator's
// ground truth the comparison (missed, spurious and wrong floors, height-change RMSE).
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <variant>

#include "args.h"
#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"
#include "storey/eval/floor_evaluation.h"
#include "storey/runtime/sensor_bag.h"

namespace storey::cli {

extern const char* const summary_floors = "floor changes in a recording (and vs ground truth)";

namespace {

std::set<std::string> splitNames(const std::string& text) {
  std::set<std::string> names;
  std::stringstream in(text);
  std::string name;
  while (std::getline(in, name, ',')) {
    if (!name.empty()) names.insert(name);
  }
  return names;
}

void printEvent(const detection::FloorEvent& e) {
  std::printf("  %9.2f .. %9.2f s  floor %d -> %d%s  dz %+7.3f +- %.3f m  %-8s  confidence %.2f\n",
              e.start_stamp, e.stamp, e.from_floor, e.floor_id,
              e.new_floor ? " (new)" : (e.floor_changed ? "      " : " (same)"), e.height_change,
              e.height_change_stddev, detection::transitModeName(e.mode), e.confidence);
}

}  // namespace

int run_floors(Args& args) {
  args.usage("BAG [--ground-truth DIR]",
             "Runs the floor detector over every robot of a rosbag2 recording (its\n"
             "/<robot>/pressure, imu, odom and scan topics; a robot without pressure gets its\n"
             "heights from the IMU and odometry) and prints each floor change:\n"
             "interval, floors, height change and its std-dev, mode, confidence.\n"
             "With --ground-truth (a `storey simulate` ground_truth folder) it also prints,\n"
             "per robot and in total, missed, spurious and wrong floors and the RMSE of the\n"
             "height changes.")
      .option("config", "FILE",
              "floor_detector parameters (its `detector` mapping is used); default: the "
              "built-in values, which equal config/floor_detector.yaml")
      .option("robot", "NAMES", "only these robots (comma-separated)")
      .option("ground-truth", "DIR", "ground-truth folder with transits.csv and floors.yaml")
      .flag("verbose", "log every transit as it is detected");
  if (!args.parse()) return 0;
  const std::string bag_path = args.positional(0, "BAG");
  if (args.positionals().size() > 1) throw UsageError("too many arguments (see --help)");
  if (!args.flagSet("verbose")) common::setLogLevel(common::LogLevel::kWarn);

  detection::FloorDetectorOptions options;
  if (args.has("config")) options = detection::loadFloorDetectorOptions(args.get("config"));
  std::set<std::string> only;
  if (args.has("robot")) only = splitNames(args.get("robot"));
  std::vector<eval::TrueTransit> truth;
  if (args.has("ground-truth")) truth = eval::readTrueTransits(args.get("ground-truth"));

  runtime::SensorBagReader reader(bag_path);
  std::map<std::string, std::unique_ptr<detection::FloorDetector>> detectors;
  std::map<std::string, std::vector<detection::FloorEvent>> events;
  for (const auto& robot : reader.robots()) {
    if (!only.empty() && !only.count(robot)) continue;
    // What the robot carries: without a pressure topic the heights come from the IMU.
    detection::FloorDetectorOptions robot_options = options;
    robot_options.sensors.barometer = reader.sensorsOf(robot).pressure;
    detectors[robot] = std::make_unique<detection::FloorDetector>(robot_options);
    events[robot];
  }
  for (const auto& name : only) {
    if (!detectors.count(name)) throw UsageError("robot '" + name + "' is not in " + bag_path);
  }
  runtime::SensorRecord record;
  while (reader.next(record)) {
    auto it = detectors.find(record.robot);
    if (it == detectors.end()) continue;
    detection::FloorDetector& detector = *it->second;
    std::visit(
        [&detector](const auto& sample) {
          using T = std::decay_t<decltype(sample)>;
          if constexpr (std::is_same_v<T, sensor::PressureSample>) detector.addPressure(sample);
          if constexpr (std::is_same_v<T, sensor::ImuSample>) detector.addImu(sample);
          if constexpr (std::is_same_v<T, sensor::OdometrySample>) detector.addOdometry(sample);
          if constexpr (std::is_same_v<T, sensor::LaserScan>) detector.addScan(sample);
        },
        record.data);
    for (auto& e : detector.takeEvents()) events[record.robot].push_back(e);
  }

  int total_transits = 0, total_missed = 0, total_spurious = 0, total_wrong = 0;
  int total_matched = 0, total_mode = 0;
  double total_squared = 0.0;
  for (const auto& [robot, detector] : detectors) {
    const auto& list = events[robot];
    const auto& stats = detector->stats();
    const bool barometer = detector->options().sensors.barometer;
    std::printf("%s: %zu %s (%zu rejected, %zu gaps)\n", robot.c_str(), stats.pressure_samples,
                barometer ? "pressure samples" : "heights from the IMU and odometry",
                stats.rejected_pressure, stats.gaps);
    if (stats.pressure_samples == 0) {
      std::printf("  no pressure and no IMU: floor changes cannot be detected\n");
    }
    std::string sequence =
        std::to_string(list.empty() ? detector->currentFloor() : list.front().from_floor);
    for (const auto& e : list) {
      if (e.type != detection::FloorEventType::kTransitEnded) continue;
      printEvent(e);
      if (e.floor_changed) sequence += " " + std::to_string(e.floor_id);
    }
    std::printf("  floor sequence: %s\n  floors:", sequence.c_str());
    for (const auto& f : detector->floors()) {
      std::printf(" %d@%.2fm", f.id, f.height);
    }
    std::printf("\n");
    if (args.has("ground-truth")) {
      std::vector<eval::TrueTransit> mine;
      for (const auto& t : truth) {
        if (t.robot == robot) mine.push_back(t);
      }
      const eval::FloorComparison c = eval::compareWithTruth(list, mine);
      std::printf(
          "  vs ground truth: %d true transits, %d reported, %d missed, %d spurious, "
          "%d wrong floors, height-change RMSE %.3f m, mode right %d/%d%s\n",
          c.true_transits, c.reported, c.missed, c.spurious, c.wrong_floor, c.height_rmse,
          c.mode_correct, c.matched, c.exact() ? " (exact)" : "");
      for (const auto& p : c.problems) std::printf("    %s\n", p.c_str());
      total_transits += c.true_transits;
      total_missed += c.missed;
      total_spurious += c.spurious;
      total_wrong += c.wrong_floor;
      total_matched += c.matched;
      total_mode += c.mode_correct;
      total_squared += c.height_rmse * c.height_rmse * c.matched;
    }
  }
  if (args.has("ground-truth")) {
    std::printf(
        "total: %d true transits, %d missed, %d spurious, %d wrong floors, "
        "height-change RMSE %.3f m, mode right %d/%d\n",
        total_transits, total_missed, total_spurious, total_wrong,
        total_matched ? std::sqrt(total_squared / total_matched) : 0.0, total_mode, total_matched);
  }
  return 0;
}

}  // namespace storey::cli
