#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "storey/bag/bag_reader.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::sim {
namespace {

namespace fs = std::filesystem;

std::string small2() { return test::sourceDir() + "/config/buildings/small2.yaml"; }

void runSimulate(const std::string& out, int seed) {
  const std::string command = std::string(STOREY_EXECUTABLE) + " simulate " + small2() +
                              " --output " + out + " --seed " + std::to_string(seed) + " > " + out +
                              ".log 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
}

// Every message of a bag as topic name, stamp and bytes, in bag order.
std::vector<std::tuple<std::string, std::int64_t, std::vector<std::uint8_t>>> messages(
    const std::string& bag_path) {
  bag::BagReader reader(bag_path);
  std::vector<std::tuple<std::string, std::int64_t, std::vector<std::uint8_t>>> result;
  bag::BagMessage message;
  while (reader.next(message))
    result.emplace_back(reader.topics()[message.topic_index].name, message.stamp_ns, message.data);
  return result;
}

TEST(SimulateCommand, SameSeedSameBytesInBagAndGroundTruth) {
  const std::string dir = test::makeTempDir("sim_cmd");
  runSimulate(dir + "/a", 5);
  runSimulate(dir + "/b", 5);
  runSimulate(dir + "/c", 6);
  for (const char* file : {"trajectory.csv", "floors.yaml", "transits.csv", "corridors.yaml"}) {
    const std::string a = test::readFile(dir + "/a/ground_truth/" + file);
    EXPECT_FALSE(a.empty()) << file;
    EXPECT_EQ(a, test::readFile(dir + "/b/ground_truth/" + file)) << file;
  }
  const auto a = messages(dir + "/a/bag");
  const auto b = messages(dir + "/b/bag");
  const auto c = messages(dir + "/c/bag");
  ASSERT_GT(a.size(), 1000u);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a == b);
  ASSERT_EQ(a.size(), c.size());  // same mission, so same sample times
  EXPECT_FALSE(a == c);           // other noise
  for (const char* picture : {"floor_F0.png", "floor_F1.png", "overlay_F0_F1.png"})
    EXPECT_TRUE(fs::exists(dir + "/a/pictures/" + picture)) << picture;
}

TEST(SimulateCommand, TheBagReplaysTheSimulatedSamples) {
  const std::string dir = test::makeTempDir("sim_replay");
  runSimulate(dir + "/out", 9);
  const Simulation run = simulate(loadScenario(small2()), 9);
  const RobotRun& robot = run.robots[0];
  runtime::SensorBagReader reader(dir + "/out/bag");
  EXPECT_EQ(reader.robots(), std::vector<std::string>{"robot1"});
  std::size_t scans = 0, odometry = 0, pressure = 0, imu = 0;
  runtime::SensorRecord record;
  while (reader.next(record)) {
    if (const auto* scan = std::get_if<sensor::LaserScan>(&record.data)) {
      ASSERT_LT(scans, robot.scans.size());
      const auto& expected = robot.scans[scans++];
      EXPECT_NEAR(scan->stamp, expected.stamp, 1e-9);
      ASSERT_EQ(scan->ranges.size(), expected.ranges.size());
      for (std::size_t i = 0; i < expected.ranges.size(); ++i) {
        if (std::isfinite(expected.ranges[i])) {
          EXPECT_EQ(scan->ranges[i], expected.ranges[i]);
        } else {
          EXPECT_FALSE(scan->isReturn(i));
        }
      }
      EXPECT_NEAR(scan->sensor_offset.x(), expected.sensor_offset.x(), 1e-9);
    } else if (const auto* odom = std::get_if<sensor::OdometrySample>(&record.data)) {
      ASSERT_LT(odometry, robot.odometry.size());
      const auto& expected = robot.odometry[odometry++];
      EXPECT_NEAR(odom->pose.x(), expected.pose.x(), 1e-9);
      EXPECT_NEAR(odom->pose.theta(), expected.pose.theta(), 1e-6);
    } else if (const auto* p = std::get_if<sensor::PressureSample>(&record.data)) {
      ASSERT_LT(pressure, robot.pressure.size());
      EXPECT_NEAR(p->pascal, robot.pressure[pressure++].pascal, 1e-6);
    } else if (std::get_if<sensor::ImuSample>(&record.data)) {
      ++imu;
    }
  }
  EXPECT_EQ(scans, robot.scans.size());
  EXPECT_EQ(odometry, robot.odometry.size());
  EXPECT_EQ(pressure, robot.pressure.size());
  EXPECT_EQ(imu, robot.imu.size());
}

TEST(EvaluateCommand, TruthScoresZeroAndDeadReckoningDoesNot) {
  const std::string dir = test::makeTempDir("sim_eval");
  runSimulate(dir + "/out", 4);
  const auto evaluate = [&](const std::string& result, const std::string& json) {
    const std::string command = std::string(STOREY_EXECUTABLE) + " evaluate " + result + " " + dir +
                                "/out --json " + json + " > " + json + ".txt 2>&1";
    EXPECT_EQ(std::system(command.c_str()), 0) << test::readFile(json + ".txt");
    return test::readFile(json);
  };
  const std::string truth = evaluate(dir + "/out/ground_truth", dir + "/truth.json");
  EXPECT_NE(truth.find("\"ate_rmse\": 0,"), std::string::npos) << truth;
  EXPECT_NE(truth.find("\"ratio\": 1}"), std::string::npos) << truth;
  const std::string baseline = evaluate(dir + "/out/baseline_odometry", dir + "/odom.json");
  EXPECT_EQ(baseline.find("\"ate_rmse\": 0,"), std::string::npos) << baseline;
  EXPECT_NE(baseline.find("\"matched\": 579"), std::string::npos) << baseline;
  EXPECT_NE(test::readFile(dir + "/odom.json.txt").find("relations"), std::string::npos);
  // A malformed result names its file and line.
  std::ofstream(dir + "/bad.csv") << "stamp,robot,floor,x,y,theta,z\n0,robot1,F0,1,2,x,0\n";
  const std::string command = std::string(STOREY_EXECUTABLE) + " evaluate " + dir + "/bad.csv " +
                              dir + "/out > " + dir + "/bad.txt 2>&1";
  EXPECT_NE(std::system(command.c_str()), 0);
  EXPECT_NE(test::readFile(dir + "/bad.txt").find("bad.csv:2: theta"), std::string::npos)
      << test::readFile(dir + "/bad.txt");
}

TEST(SimulateCommand, ImpossibleMissionFailsWithTheLine) {
  const std::string dir = test::makeTempDir("sim_bad");
  std::string text = test::readFile(small2());
  const std::string good = "      - {go: [10.5, 2.5]}";
  const auto at = text.find(good);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, good.size(), "      - {go: [13.0, 2.5]}");  // inside wall room_e on F0
  std::ofstream(dir + "/bad.yaml") << text;
  fs::create_directories(dir + "/robots");
  fs::copy_file(test::sourceDir() + "/config/robots/default.yaml", dir + "/robots/default.yaml");
  fs::create_directories(dir + "/buildings");
  fs::rename(dir + "/bad.yaml", dir + "/buildings/bad.yaml");
  const std::string command = std::string(STOREY_EXECUTABLE) + " simulate " + dir +
                              "/buildings/bad.yaml --output " + dir + "/out > " + dir + "/log 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(command.c_str())), 1);
  const std::string log = test::readFile(dir + "/log");
  EXPECT_NE(log.find("bad.yaml:"), std::string::npos) << log;
  EXPECT_NE(log.find("waypoint (13, 2.5)"), std::string::npos) << log;
}

}  // namespace
}  // namespace storey::sim
