// `storey map` on the bundled building: simulation, all four components over DDS in one
// process, outputs, and accuracy against the simulator's ground truth.
#include "storey/tools/map_job.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/common/config.h"
#include "storey/eval/trajectory.h"
#include "storey/io/carmen.h"
#include "storey/runtime/context.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/subscription.h"
#include "storey/sim/ground_truth.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/robot_setup.h"
#include "storey/tools/simulation_bag.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;

MapJobOptions bundled(int domain, const std::string& out) {
  MapJobOptions options;
  options.domain_id = domain;
  options.output_dir = out;
  options.quiet = true;
  return options;
}

TEST(MapJob, BundledBuildingIsMappedAndAligned) {
  const std::string out = test::makeTempDir("storey_map");
  const MapJobResult result = runMapJob(bundled(210, out));
  EXPECT_EQ(result.scenario, "small2");
  EXPECT_EQ(result.outputs.floors, 2u);
  EXPECT_GE(result.outputs.constraints, 3u);
  for (const char* file : {"floor_0.pgm", "floor_0.yaml", "floor_1.pgm", "building.yaml", "graph.g2o",
                           "trajectory.csv", "building.bt", "report.html", "overlay.png", "journal.bin",
                           "building_before.png", "building_after.png"})
    EXPECT_TRUE(fs::exists(fs::path(out) / file)) << file;
  ASSERT_TRUE(result.evaluation.has_value());
  ASSERT_TRUE(result.evaluation_unaligned.has_value());
  ASSERT_EQ(result.evaluation->floors.size(), 2u);
  // Inter-floor constraints must bring the floors into one frame: the rotation residual of
  // every floor falls far below what the unaligned floors show (tens of degrees), and every
  // floor meets the 0.05 m / 0.2 degree goal (docs/map.md, seed 1: F0 0.004 m / 0.018 deg,
  // F1 0.007 m / 0.035 deg).
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& with = result.evaluation->floors[i];
    const auto& without = result.evaluation_unaligned->floors[i];
    EXPECT_LT(with.residual_rotation, 0.5 * without.residual_rotation) << with.floor;
    EXPECT_LT(with.residual_rotation * 180 / M_PI, 0.2) << with.floor;
    EXPECT_LT(with.residual_translation, 0.05) << with.floor;
  }
  EXPECT_LT(result.evaluation->ate_rmse, result.evaluation_unaligned->ate_rmse);
  // The OctoMap holds occupied voxels on both floors (small2: heights 0 and 3.5 m).
  octomap::OcTree tree((fs::path(out) / "building.bt").string());
  int ground = 0, upper = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    (it.getZ() < 3.0 ? ground : upper)++;
  }
  EXPECT_GT(ground, 1000);
  EXPECT_GT(upper, 1000);
  // The report's numbers are for people: no exponent notation, and every phase timed,
  // the outputs included.
  const std::string report = test::readFile((fs::path(out) / "report.html").string());
  EXPECT_EQ(report.find("e-0"), std::string::npos);
  EXPECT_EQ(report.find("e-1"), std::string::npos);
  EXPECT_EQ(report.find("<td>-0.000</td>"), std::string::npos);
  EXPECT_NE(report.find("<td style=\"text-align:left\">outputs"), std::string::npos);
  // Its first section says whether the building came out right.
  const std::size_t summary = report.find("<h2>Summary</h2>");
  ASSERT_NE(summary, std::string::npos);
  EXPECT_LT(summary, report.find("<h2>Floors</h2>"));
  EXPECT_NE(report.find("2 floors, 1 robot, 2 floor graphs"), std::string::npos);
  EXPECT_NE(report.find("every floor graph is placed by them"), std::string::npos);
  EXPECT_EQ(report.find("class=\"warn\""), std::string::npos);
  EXPECT_NE(report.find("Against ground truth: every floor within"), std::string::npos);
  // The timeline: small2's robot rides the lift up and takes the stairs down.
  EXPECT_NE(report.find("<h2>Timeline</h2>"), std::string::npos);
  EXPECT_NE(report.find("<svg"), std::string::npos);
  EXPECT_NE(report.find("<td>F0</td><td>F1 (new)</td>"), std::string::npos);
  EXPECT_NE(report.find("<td>F1</td><td>F0</td>"), std::string::npos);
  EXPECT_NE(report.find("<td>elevator</td>"), std::string::npos);
  EXPECT_NE(report.find("<td>stairs</td>"), std::string::npos);
}

// A robot without a barometer (its bag has no pressure topic): the floor detector takes
// heights from the IMU and odometry, and every floor still meets the 0.05 m / 0.2 degree
// goal.
TEST(MapJob, ARobotWithoutABarometerIsMappedFromItsImu) {
  const std::string out = test::makeTempDir("storey_map_imu");
  MapJobOptions options = bundled(56, out);
  options.without_barometer = true;
  const MapJobResult result = runMapJob(options);
  EXPECT_FALSE(runtime::SensorBagReader(out + "/recording/bag").sensorsOf("robot1").pressure);
  EXPECT_EQ(result.outputs.floors, 2u);
  EXPECT_GE(result.outputs.constraints, 3u);
  ASSERT_TRUE(result.evaluation.has_value());
  ASSERT_EQ(result.evaluation->floors.size(), 2u);
  for (const auto& floor : result.evaluation->floors) {
    EXPECT_LT(floor.residual_rotation * 180 / M_PI, 0.2) << floor.floor;
    EXPECT_LT(floor.residual_translation, 0.05) << floor.floor;
  }
}

TEST(MapJob, SameSeedGivesTheSameBuilding) {
  const std::string a = test::makeTempDir("storey_map_a"), b = test::makeTempDir("storey_map_b");
  runMapJob(bundled(211, a));
  runMapJob(bundled(212, b));
  EXPECT_EQ(test::readFile(a + "/building.yaml"), test::readFile(b + "/building.yaml"));
  EXPECT_EQ(test::readFile(a + "/trajectory.csv"), test::readFile(b + "/trajectory.csv"));
}

// An offline job beside a live replay on the same DDS domain: the replay publishes another
// recording under the same robot name (small2, seed 2) for the whole job, and a listener
// on the domain checks that it does. The job must write byte for byte the building it
// writes alone.
TEST(MapJob, AReplayOnTheSameDomainDoesNotChangeTheBuilding) {
  constexpr int kDomain = 225;
  const std::string dir = test::makeTempDir("storey_map_beside_replay");
  writeSimulationBag(sim::simulate(sim::loadScenario(defaultBuilding(defaultConfigDir())), 2),
                     dir + "/other_bag");
  runMapJob(bundled(kDomain, dir + "/alone"));

  const pid_t replay = fork();
  ASSERT_GE(replay, 0);
  if (replay == 0) {
    const std::string domain = std::to_string(kDomain), bag = dir + "/other_bag";
    execl(STOREY_EXECUTABLE, STOREY_EXECUTABLE, "replay", bag.c_str(), "--domain", domain.c_str(),
          "--rate", "5", "--wait", "0", "--quiet", static_cast<char*>(nullptr));
    _exit(127);
  }
  struct Stop {
    pid_t pid;
    ~Stop() {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  } stop{replay};
  runtime::ContextOptions listener_options;
  listener_options.domain_id = kDomain;
  runtime::Context listener(listener_options);
  std::atomic<int> scans{0};
  runtime::Subscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType> sub(
      listener, "robot1/scan", runtime::TopicKind::kSensor, [&](const auto&) { ++scans; });
  for (int i = 0; i < 2000 && scans == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GT(scans, 0) << "the replay publishes nothing";
  runMapJob(bundled(kDomain, dir + "/beside"));
  const int during = scans;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_GT(scans, during) << "the replay ended before the job";

  for (const char* file :
       {"building.yaml", "trajectory.csv", "graph.g2o", "floor_0.pgm", "floor_1.pgm"})
    EXPECT_TRUE(test::readFile(dir + "/alone/" + file) == test::readFile(dir + "/beside/" + file))
        << file << " differs";
}

// Floors recorded on their own (the paper's setting), here small2's robot before and after
// its ride as two CARMEN logs given as A@0:0 and B@1:3.5. Each log's robot maps its own
// floor from its first scan: one graph each, on its floor. Its mapper starts there (a
// floor event would be ordered among the scans by stamp; a first scan stamped no later
// would make a one-node graph on floor 0).
TEST(MapJob, FloorsRecordedSeparatelyAreMappedOnTheirOwnFloors) {
  const std::string dir = test::makeTempDir("storey_map_floors");
  const sim::Simulation run =
      sim::simulate(sim::loadScenario(defaultBuilding(defaultConfigDir())), 1);
  const sim::RobotRun& robot = run.robots.at(0);
  ASSERT_FALSE(robot.transits.empty());
  const sim::Transit& ride = robot.transits.front();
  // Each log's stamps start at 0, as a log recorded on its own may.
  auto writeLog = [&](const std::string& path, double from, double to) {
    io::CarmenWriter writer(path);
    std::size_t odometry = 0;
    double first = -1.0;
    for (const auto& scan : robot.scans) {
      if (scan.stamp < from || scan.stamp > to) continue;
      while (odometry + 1 < robot.odometry.size() &&
             robot.odometry[odometry + 1].stamp <= scan.stamp)
        ++odometry;
      if (first < 0) first = scan.stamp;
      io::CarmenLaser laser;
      laser.scan = scan;
      laser.scan.stamp -= first;
      laser.has_pose = true;
      laser.odom_pose = robot.odometry[odometry].pose;
      laser.laser_pose = laser.odom_pose * scan.sensor_offset;
      writer.flaser(laser);
    }
    writer.close();
  };
  writeLog(dir + "/F0.log", 0.0, ride.start);
  writeLog(dir + "/F1.log", ride.end + 2.0, 1e9);
  MapJobOptions options = bundled(225, dir + "/out");
  options.inputs = {parseMapInput(dir + "/F0.log@0:0"), parseMapInput(dir + "/F1.log@1:3.5")};
  options.keep_graph = true;
  const MapJobResult result = runMapJob(options);
  ASSERT_TRUE(result.graph);
  std::map<std::string, std::vector<const floor::FloorGraph*>> by_robot;
  for (const auto& [id, g] : result.graph->floorGraphs()) by_robot[g.robot].push_back(&g);
  ASSERT_EQ(by_robot.size(), 2u);
  ASSERT_EQ(by_robot.at("floor0").size(), 1u);
  ASSERT_EQ(by_robot.at("floor1").size(), 1u)
      << "the floor-1 log's robot has a graph on another floor";
  EXPECT_EQ(by_robot.at("floor0")[0]->floor_id, 0);
  EXPECT_EQ(by_robot.at("floor1")[0]->floor_id, 1);
  EXPECT_DOUBLE_EQ(by_robot.at("floor1")[0]->floor_height, 3.5);
  EXPECT_GT(by_robot.at("floor1")[0]->nodes.size(), 10u);
  // The mapper of such a robot starts on its floor and waits for no floor detector.
  RobotSetup setup;
  setup.recorded_floor["floor1"] = {1, 3.5};
  const YAML::Node mapper = floorMapperParameters(defaultConfigDir(), "floor1", setup);
  EXPECT_EQ(mapper["initial_floor"].as<int>(), 1);
  EXPECT_DOUBLE_EQ(mapper["initial_height"].as<double>(), 3.5);
  EXPECT_FALSE(mapper["wait_for_floor_detector"].as<bool>());
}

TEST(MapJob, BadInputsAreReportedClearly) {
  MapJobOptions options = bundled(213, test::makeTempDir("storey_map_bad"));
  options.inputs = {{"/nonexistent/recording", {}, {}, ""}};
  try {
    runMapJob(options);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/recording"), std::string::npos);
  }
  EXPECT_THROW(parseMapInput("a.log@x"), std::invalid_argument);
  // A height or floor with no meaning is refused, naming the input.
  for (const char* bad :
       {"a.log@0:nan", "a.log@0:inf", "a.log@1:-inf", "a.log@0:1e300", "a.log@5000"}) {
    try {
      parseMapInput(bad);
      ADD_FAILURE() << "accepted " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  const MapInput parsed = parseMapInput("/tmp/a.log@2:7.5");
  EXPECT_EQ(parsed.path, "/tmp/a.log");
  EXPECT_EQ(*parsed.floor, 2);
  EXPECT_DOUBLE_EQ(*parsed.height, 7.5);
  const std::string dir = test::makeTempDir("storey_floors");
  std::ofstream(dir + "/floors.yaml") << "floors:\n  - {path: missing.log, floor: 0, height: 0}\n";
  EXPECT_THROW(readMapInputs(dir + "/floors.yaml"), common::ConfigError);
}

// A recorded fleet mapped from its bag (fleet seed 1: robot1 and robot2 start on F0,
// robot3 on F3). With the robots file every detector knows the floor heights and its
// robot's start floor, so each pose lands on its true floor and the floors are aligned;
// without it each robot numbers floors from where it started, and robot3's poses are
// put on the wrong floors.
TEST(MapJob, ARecordedFleetTakesItsRobotsFloorsFromTheRobotsFile) {
  const sim::Scenario scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/fleet.yaml");
  const sim::Simulation run = sim::simulate(scenario, 1);
  const std::string dir = test::makeTempDir("storey_fleet_bag");
  writeSimulationBag(run, dir + "/bag");
  sim::writeGroundTruth(run, dir + "/ground_truth");
  {
    std::ofstream robots(dir + "/robots.yaml");
    robots << "floor_heights: [";
    for (std::size_t i = 0; i < scenario.building.floors.size(); ++i)
      robots << (i ? ", " : "") << scenario.building.floors[i].height;
    robots << "]\nrobots:\n";
    for (const auto& robot : scenario.robots)
      robots << "  " << robot.name << ": {start_floor: " << scenario.building.floorIndex(robot.start_floor) << "}\n";
  }
  const auto truth = eval::readTrajectoryCsv(dir + "/ground_truth/trajectory.csv");
  std::map<std::pair<std::string, long long>, std::string> true_floor;  // (robot, ms) -> floor index
  for (const auto& row : truth)
    true_floor[{row.robot, std::llround(row.stamp * 1000.0)}] =
        std::to_string(scenario.building.floorIndex(row.floor));
  // Per robot, the fraction of its estimated poses on their true floor.
  auto onTrueFloor = [&](const std::string& out) {
    std::map<std::string, std::pair<int, int>> counts;  // robot -> (right, all)
    for (const auto& row : eval::readTrajectoryCsv(out + "/trajectory.csv")) {
      const auto it = true_floor.find({row.robot, std::llround(row.stamp * 1000.0)});
      if (it == true_floor.end()) continue;
      counts[row.robot].first += row.floor == it->second;
      ++counts[row.robot].second;
    }
    std::map<std::string, double> fraction;
    for (const auto& [robot, c] : counts) fraction[robot] = static_cast<double>(c.first) / c.second;
    return fraction;
  };

  MapJobOptions with = bundled(207, dir + "/with");
  with.inputs = {{dir + "/bag", {}, {}, ""}};
  with.robot_floors = readRobotFloors(dir + "/robots.yaml");
  runMapJob(with);
  const auto right = onTrueFloor(with.output_dir);
  ASSERT_EQ(right.size(), 3u);
  for (const auto& [robot, fraction] : right) EXPECT_GT(fraction, 0.95) << robot;
  const eval::Evaluation evaluation =
      eval::evaluate(eval::readTrajectoryCsv(with.output_dir + "/trajectory.csv"), truth);
  ASSERT_EQ(evaluation.floors.size(), 4u);
  for (const auto& f : evaluation.floors) {
    EXPECT_LT(f.residual_translation, 0.05) << f.floor;
    EXPECT_LT(f.residual_rotation, 0.2 * M_PI / 180.0) << f.floor;
  }

  MapJobOptions without = bundled(208, dir + "/without");
  without.inputs = with.inputs;
  runMapJob(without);
  EXPECT_LT(onTrueFloor(without.output_dir).at("robot3"), 0.5);
}

TEST(MapJob, TheRobotsFileIsReadStrictly) {
  const std::string dir = test::makeTempDir("storey_robots_file");
  auto write = [&](const std::string& text) {
    std::ofstream(dir + "/robots.yaml") << text;
    return dir + "/robots.yaml";
  };
  const RobotFloors ok = readRobotFloors(write("floor_heights: [0, 3.5, 7]\nrobots:\n  a: {start_floor: 2}\n"));
  EXPECT_EQ(ok.heights.size(), 3u);
  EXPECT_EQ(ok.start_floor.at("a"), 2);
  for (const std::string bad : {"floor_heights: [0, 3.5]\nrobots:\n  a: {start_floor: 2}\n",  // no floor 2
                                "floor_heights: [3.5, 0]\nrobots:\n  a: {start_floor: 0}\n",  // not increasing
                                "floor_heights: []\nrobots:\n  a: {start_floor: 0}\n",
                                "floor_heights: [0]\nrobots:\n  a: {start_flor: 0}\n",  // unknown key
                                "floor_heights: [0]\nrobot:\n  a: {start_floor: 0}\n"}) {
    try {
      readRobotFloors(write(bad));
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const common::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("robots.yaml"), std::string::npos) << e.what();
    }
  }
  // A robot the recording does not hold, or a recorded robot the file leaves out, is an
  // error naming the file and the robot.
  const auto scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/small2.yaml");
  writeSimulationBag(sim::simulate(scenario, 1), dir + "/bag");
  MapJobOptions options = bundled(209, dir + "/out");
  options.inputs = {{dir + "/bag", {}, {}, ""}};
  options.robot_floors = readRobotFloors(write("floor_heights: [0, 3.5]\nrobots:\n  robot9: {start_floor: 1}\n"));
  try {
    runMapJob(options);
    ADD_FAILURE() << "a robot the file leaves out was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("robots.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no start_floor"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace storey::tools
