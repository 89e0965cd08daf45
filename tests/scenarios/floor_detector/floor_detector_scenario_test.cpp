// The floor detector on simulated buildings: several seeds with weather drift, every
// sensor, the barometer alone, or robots without a barometer (heights from the IMU and
// odometry). The floor sequence must be exact and the height changes within 0.2 m RMSE
// with a barometer, 0.3 m without.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"
#include "storey/eval/floor_evaluation.h"
#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::detection {
using eval::FloorComparison;
using eval::TrueTransit;
using eval::compareWithTruth;
namespace {

// Five seeds by default; STOREY_FLOOR_SEEDS=N runs more (for sweeps, not for CI).
int seedCount() {
  const char* text = std::getenv("STOREY_FLOOR_SEEDS");
  const int n = text ? std::atoi(text) : 0;
  return n > 0 ? n : 5;
}

FloorDetectorOptions shippedOptions() {
  return loadFloorDetectorOptions(storey::test::sourceDir() + "/config/floor_detector.yaml");
}

// Feeds one simulated robot's streams to a detector in stamp order.
std::vector<FloorEvent> detect(const sim::RobotRun& run, FloorDetector& detector,
                               bool corroborate) {
  struct Item {
    double t;
    int stream;
    std::size_t index;
  };
  std::vector<Item> items;
  for (std::size_t i = 0; i < run.pressure.size(); ++i)
    items.push_back({run.pressure[i].stamp, 0, i});
  if (corroborate) {
    for (std::size_t i = 0; i < run.imu.size(); ++i) items.push_back({run.imu[i].stamp, 1, i});
    for (std::size_t i = 0; i < run.odometry.size(); ++i)
      items.push_back({run.odometry[i].stamp, 2, i});
    for (std::size_t i = 0; i < run.scans.size(); ++i) items.push_back({run.scans[i].stamp, 3, i});
  }
  std::stable_sort(items.begin(), items.end(),
                   [](const Item& a, const Item& b) { return a.t < b.t; });
  std::vector<FloorEvent> events;
  for (const auto& item : items) {
    switch (item.stream) {
      case 0:
        detector.addPressure(run.pressure[item.index]);
        break;
      case 1:
        detector.addImu(run.imu[item.index]);
        break;
      case 2:
        detector.addOdometry(run.odometry[item.index]);
        break;
      default:
        detector.addScan(run.scans[item.index]);
        break;
    }
    for (auto& e : detector.takeEvents()) events.push_back(e);
  }
  return events;
}

std::vector<TrueTransit> truthOf(const sim::Simulation& simulation, const sim::RobotRun& run) {
  std::vector<TrueTransit> truth;
  for (const auto& t : run.transits) {
    TrueTransit tt;
    tt.robot = t.robot;
    tt.start = t.start;
    tt.end = t.end;
    tt.from_floor = simulation.building.floors[t.from_floor].id;
    tt.to_floor = simulation.building.floors[t.to_floor].id;
    tt.height_change = simulation.building.floors[t.to_floor].height -
                       simulation.building.floors[t.from_floor].height;
    tt.mode = t.mode;
    truth.push_back(tt);
  }
  return truth;
}

struct Totals {
  int transits = 0, exact_runs = 0, runs = 0, mode_correct = 0, matched = 0;
  double squared = 0.0;
};

enum class Sensors { kAll, kBarometerOnly, kWithoutBarometer };

void runSeeds(const sim::Scenario& scenario, int seeds, Sensors sensors, Totals& totals) {
  const bool corroborate = sensors != Sensors::kBarometerOnly;
  for (int seed = 1; seed <= seeds; ++seed) {
    sim::SimulateOptions options;
    options.seed = static_cast<std::uint64_t>(seed);
    options.without_barometer = sensors == Sensors::kWithoutBarometer;
    const sim::Simulation simulation = sim::simulate(scenario, options);
    for (const auto& run : simulation.robots) {
      FloorDetectorOptions detector_options = shippedOptions();
      // What the robot carries: a robot model may have no barometer either.
      detector_options.sensors.barometer = !run.pressure.empty();
      const double max_rmse = detector_options.sensors.barometer ? 0.2 : 0.3;
      FloorDetector detector(detector_options);
      const auto events = detect(run, detector, corroborate);
      const auto truth = truthOf(simulation, run);
      const FloorComparison c = compareWithTruth(events, truth);
      ++totals.runs;
      totals.transits += c.true_transits;
      totals.matched += c.matched;
      totals.mode_correct += c.mode_correct;
      totals.squared += c.height_rmse * c.height_rmse * c.matched;
      if (c.exact()) ++totals.exact_runs;
      std::string problems;
      for (const auto& p : c.problems) problems += "\n  " + p;
      EXPECT_TRUE(c.exact()) << scenario.name << " seed " << seed << " robot " << run.name
                             << " (drift " << simulation.pressure_drift * 36.0 << " hPa/h)"
                             << problems;
      EXPECT_LT(c.height_rmse, max_rmse) << scenario.name << " seed " << seed;
    }
  }
}

void report(const char* what, const Totals& t) {
  const double rmse = t.matched > 0 ? std::sqrt(t.squared / t.matched) : 0.0;
  std::printf("%s: %d/%d runs exact, %d transits, height-change RMSE %.3f m, mode right %d/%d\n",
              what, t.exact_runs, t.runs, t.transits, rmse, t.mode_correct, t.matched);
}

// Runs the seeds, prints the totals and expects every run exact (and, with corroborating
// sensors, every mode right).
void expectExact(const sim::Scenario& scenario, Sensors sensors, const std::string& what) {
  common::setLogLevel(common::LogLevel::kWarn);
  Totals totals;
  runSeeds(scenario, seedCount(), sensors, totals);
  report(what.c_str(), totals);
  EXPECT_EQ(totals.exact_runs, totals.runs) << what;
  if (sensors != Sensors::kBarometerOnly) EXPECT_EQ(totals.mode_correct, totals.matched) << what;
}

// The bundled building, with the weather drift raised to 1 hPa/h.
sim::Scenario small2() {
  sim::Scenario scenario =
      sim::loadScenario(storey::test::sourceDir() + "/config/buildings/small2.yaml");
  scenario.building.atmosphere.max_drift_hpa_per_hour = 1.0;
  return scenario;
}

TEST(FloorDetectorScenario, Small2AllSensorsSeeds) {
  expectExact(small2(), Sensors::kAll, "small2, all sensors");
}

TEST(FloorDetectorScenario, Small2BarometerOnlySeeds) {
  expectExact(small2(), Sensors::kBarometerOnly, "small2, barometer only");
}

// A four-storey tower with uneven storeys, long waits (drift), elevator rides over
// several floors both ways, stairs up and down and a 0.6 m ramp (not a floor); two robots.
sim::Scenario tower() {
  const std::string text = R"(name: tower4
building:
  name: tower4
  atmosphere: {sea_level_pressure: 101325.0, sea_level_temperature: 288.15, altitude: 400.0,
               max_drift_hpa_per_hour: 1.0}
  shafts:
    - {id: E, kind: elevator, center: [10.0, 8.0], size: [2.0, 2.0], door_side: south, door_width: 1.0}
    - {id: S, kind: stairs, center: [17.0, 9.0], size: [2.4, 4.0], door_side: south, door_width: 1.0}
  floors:
    - id: G
      height: 0.0
      walls:
        - {id: outer, rect: [[0.0, 0.0], [20.0, 12.0]]}
        - {id: corridor_south, polyline: [[0.0, 5.0], [20.0, 5.0]]}
      doors:
        - {id: d_s, span: [[10.0, 5.0], [11.0, 5.0]], open: true}
    - {id: L1, height: 4.5, like: G}
    - {id: L2, height: 8.0, like: G}
    - {id: L3, height: 11.5, like: G}
robots:
  - name: alpha
    model: default
    start: {floor: G, pose: [2.0, 6.0, 0.0]}
    mission:
      - {go: [9.0, 6.0]}
      - {elevator: E, to: L2}
      - {go: [3.0, 6.0]}
      - {wait: 240}
      - {go: [10.5, 6.0]}
      - {elevator: E, to: L1}
      - {go: [16.5, 6.0]}
      - {stairs: S, to: L2}
      - {go: [12.0, 6.0]}
      - {elevator: E, to: L3}
      - {wait: 60}
      - {elevator: E, to: G}
      - {go: [15.0, 6.0]}
      - {stairs: S, to: L1}
      - {wait: 120}
      - {stairs: S, to: G}
  - name: beta
    model: default
    start: {floor: L3, pose: [5.0, 6.0, 0.0], time: 5.0}
    mission:
      - {wait: 5}
      - {go: [8.0, 6.0], rise: 0.6}
      - {wait: 30}
      - {go: [5.0, 6.0], rise: -0.6}
      - {go: [15.5, 6.0]}
      - {stairs: S, to: L2}
      - {go: [11.0, 6.0]}
      - {elevator: E, to: G}
      - {wait: 180}
      - {elevator: E, to: L3}
      - {go: [4.0, 6.0]}
)";
  return sim::loadScenarioString(text, "tower4.yaml", storey::test::sourceDir() + "/config/robots");
}

TEST(FloorDetectorScenario, TowerAllSensorsSeeds) {
  expectExact(tower(), Sensors::kAll, "tower4, all sensors");
}

TEST(FloorDetectorScenario, TowerBarometerOnlySeeds) {
  expectExact(tower(), Sensors::kBarometerOnly, "tower4, barometer only");
}

// A noisier barometer (3 Pa, 25 cm per sample) and only the barometer.
TEST(FloorDetectorScenario, TowerNoisyBarometerOnlySeeds) {
  sim::Scenario scenario = tower();
  for (auto& robot : scenario.robots) robot.model.barometer.sigma = 3.0;
  expectExact(scenario, Sensors::kBarometerOnly, "tower4, 3 Pa barometer only");
}
TEST(FloorDetectorScenario, TowerWithoutBarometerSeeds) {
  expectExact(tower(), Sensors::kWithoutBarometer, "tower4, no barometer");
}

// Every bundled building, its robots without a barometer.
TEST(FloorDetectorScenario, EveryBundledBuildingWithoutBarometerSeeds) {
  std::vector<std::string> files;
  for (const auto& entry :
       std::filesystem::directory_iterator(storey::test::sourceDir() + "/config/buildings")) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 9u);
  for (const auto& file : files) {
    expectExact(sim::loadScenario(file), Sensors::kWithoutBarometer,
                std::filesystem::path(file).stem().string());
  }
}

// A fleet mixing both kinds: the second robot carries no barometer.
TEST(FloorDetectorScenario, FleetMixingRobotsWithAndWithoutBarometer) {
  sim::Scenario scenario =
      sim::loadScenario(storey::test::sourceDir() + "/config/buildings/fleet.yaml");
  ASSERT_GE(scenario.robots.size(), 2u);
  scenario.robots[1].model.barometer.present = false;
  expectExact(scenario, Sensors::kAll, "fleet, mixed");
}
}  // namespace
}  // namespace storey::detection
