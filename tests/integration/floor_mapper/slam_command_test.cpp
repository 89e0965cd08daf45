// `storey slam` on a bag end to end: simulate a robot into a bag, map its scans with the
// recorded odometry, and compare with the simulator's ground truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <regex>
#include <string>

#include "storey/runtime/sensor_bag.h"
#include "test_support.h"

namespace {

// The translation mean of report line "  <who> <range> pairs: N  translation X ± ...".
double translation(const std::string& report, const std::string& who, const std::string& range) {
  const std::regex line("  " + who + " +" + range + " +pairs: [0-9]+  translation ([0-9.]+)");
  std::smatch m;
  if (!std::regex_search(report, m, line)) return -1.0;
  return std::stod(m[1]);
}

std::size_t lineCount(const std::string& path) {
  std::ifstream in(path);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

// Copies `from` to `to` with every line containing `key` replaced by `replacement`; returns
// how many were.
std::size_t copyReplacingLines(const std::string& from, const std::string& to,
                               const std::string& key, const std::string& replacement) {
  std::ifstream in(from);
  std::ofstream out(to);
  std::size_t replaced = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.find(key) != std::string::npos) {
      line = replacement;
      ++replaced;
    }
    out << line << '\n';
  }
  return replaced;
}

class SlamCommand : public ::testing::Test {
 protected:
  const std::string storey = STOREY_COMMAND;
  const std::string config = storey::test::sourceDir() + "/config/floor_mapper.yaml";

  // small2 simulated for `seconds` (0: its whole mission) into a new folder.
  std::string simulate(double seconds) {
    const std::string dir = storey::test::makeTempDir("slam_cmd");
    storey::test::CommandResult r = storey::test::runCommand(
        storey + " simulate " + storey::test::sourceDir() +
        "/config/buildings/small2.yaml --seed 1 --no-pictures --max-duration " +
        std::to_string(seconds) + " --output " + dir + "/sim");
    EXPECT_EQ(r.status, 0) << r.output;
    return dir;
  }
};

// The robot's first minute stays on floor 0 (its ride starts at 66 s): one floor graph.
TEST_F(SlamCommand, MapsABagsFloorWithItsOdometryAgainstTheTruth) {
  const std::string dir = simulate(60.0);
  storey::test::CommandResult r = storey::test::runCommand(
      storey + " slam " + dir + "/sim --config " + config + " --output " + dir + "/slam --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s", r.output.c_str());
  EXPECT_NE(r.output.find("bag: " + dir + "/sim/bag"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("odometry: recorded in the bag (robot robot1)"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("rides:"), std::string::npos) << "no ride in the first minute: one graph";
  // Measured: nearby 0.004 m, far 0.043 m against the odometry's 0.29 m.
  const double nearby = translation(r.output, "slam", "nearby");
  const double far = translation(r.output, "slam", "far");
  const double odometry_far = translation(r.output, "odometry", "far");
  ASSERT_GE(nearby, 0.0) << r.output;
  ASSERT_GE(far, 0.0) << r.output;
  EXPECT_LT(nearby, 0.01);
  EXPECT_LT(far, 0.1);
  EXPECT_LT(far, odometry_far / 3.0) << "the map should hold the odometry's drift";
  // The odometry model fitted to the graph's odometry edges, by the graph's own poses and by
  // the truth's, for calibrating slam.odometry_noise (the rates are checked in unit tests).
  EXPECT_NE(r.output.find("odometry noise fitted to the finished graph ("), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("odometry noise fitted to the reference ("), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("configured (slam.odometry_noise):"), std::string::npos) << r.output;
  EXPECT_EQ(lineCount(dir + "/slam/trajectory.csv"), 181u + 1u) << "a row per scan and a header";
  EXPECT_GT(lineCount(dir + "/slam/graph.g2o"), 100u);
  EXPECT_TRUE(std::ifstream(dir + "/slam/map.png").good());
}

// The whole mission rides to floor 1 and back. The floor detector's rides split the scans
// as in the floor_mapper component: floor 0 resumed after global relocalisation, floor 1
// its own graph, each written to its own folder and compared with the truth over its nodes.
TEST_F(SlamCommand, MapsEachFloorOfABagIntoItsOwnGraph) {
  const std::string dir = simulate(0.0);
  storey::test::CommandResult r = storey::test::runCommand(
      storey + " slam " + dir + "/sim --config " + config + " --output " + dir + "/slam --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s", r.output.c_str());
  EXPECT_NE(r.output.find("rides: 2 (floor detector)  floor graphs: 2  global relocalisations: 1  "
                          "fallbacks to a new graph: 0"),
            std::string::npos)
      << r.output;
  for (const std::string floor : {"floor_0_graph_0", "floor_1_graph_1"}) {
    SCOPED_TRACE(floor);
    const std::size_t at = r.output.find(floor + ": nodes: ");
    ASSERT_NE(at, std::string::npos) << r.output;
    const std::string section = r.output.substr(at);
    // Measured: floor 0 nearby 0.0047 m, far 0.023 m (odometry 0.78 m); floor 1 0.0034 m.
    const double nearby = translation(section, "slam", "nearby");
    ASSERT_GE(nearby, 0.0) << section;
    EXPECT_LT(nearby, 0.01);
    const std::string head = section.substr(0, section.find("relation error"));
    EXPECT_NE(head.find("odometry noise fitted to its finished graph ("), std::string::npos)
        << section;
    EXPECT_NE(head.find("odometry noise fitted to the reference ("), std::string::npos) << section;
    EXPECT_GT(lineCount(dir + "/slam/" + floor + "/trajectory.csv"), 100u);
    EXPECT_GT(lineCount(dir + "/slam/" + floor + "/graph.g2o"), 100u);
    EXPECT_TRUE(std::ifstream(dir + "/slam/" + floor + "/map.png").good());
  }
  // Floor 0 spans both visits: the map holds the odometry's drift over the ride to floor 1.
  const std::string floor0 = r.output.substr(r.output.find("floor_0_graph_0: "));
  const double far = translation(floor0, "slam", "far");
  ASSERT_GE(far, 0.0) << floor0;
  EXPECT_LT(far, 0.1);
  EXPECT_LT(far, translation(floor0, "odometry", "far") / 3.0);
  EXPECT_FALSE(std::ifstream(dir + "/slam/graph.g2o").good()) << "no graph of both floors";

  // The floor detector's options come from --detector-config: a robot that needs 10 m/s of
  // climb to start a ride never rides here, and its scans make one graph.
  const std::string shipped = storey::test::sourceDir() + "/config/floor_detector.yaml";
  const std::string slow = dir + "/no_rides.yaml";
  ASSERT_EQ(copyReplacingLines(shipped, slow, "start_velocity:", "    start_velocity: 10.0"), 1u);
  r = storey::test::runCommand(storey + " slam " + dir + "/sim --config " + config +
                               " --detector-config " + slow + " --max-scans 300 --output " + dir +
                               "/slam_no_rides --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("rides:"), std::string::npos) << r.output;
  EXPECT_TRUE(std::ifstream(dir + "/slam_no_rides/graph.g2o").good()) << "one graph";
  // A detector file with a misspelt key is refused, naming the file, the line and the key.
  const std::string typo = dir + "/typo.yaml";
  ASSERT_EQ(copyReplacingLines(shipped, typo, "start_velocity:", "    start_velocty: 0.05"), 1u);
  r = storey::test::runCommand(storey + " slam " + dir + "/sim --detector-config " + typo +
                               " --output " + dir + "/slam_typo --quiet");
  EXPECT_NE(r.status, 0);
  // The error names the mapping that lacks the key where its keys start: the misspelt one.
  int typo_line = 0;
  {
    std::ifstream in(typo);
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      if (line.find("start_velocty:") != std::string::npos) typo_line = n;
    }
  }
  ASSERT_GT(typo_line, 0);
  EXPECT_NE(r.output.find(typo + ":" + std::to_string(typo_line) +
                          ": detector.transit.start_velocity: missing required key"),
            std::string::npos)
      << r.output;
}

TEST_F(SlamCommand, RefusesWhatABagCannotGive) {
  const std::string dir = simulate(10.0);
  const std::string bag = dir + "/sim/bag";
  storey::test::CommandResult r =
      storey::test::runCommand(storey + " slam " + bag + " --robot nobody");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("robot 'nobody' is not in " + bag), std::string::npos) << r.output;
  r = storey::test::runCommand(storey + " slam " + bag + " --odometry simulated");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("a bag's odometry is recorded"), std::string::npos) << r.output;
  r = storey::test::runCommand(storey + " slam " + bag + " --truth " + dir + "/missing.csv");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(dir + "/missing.csv"), std::string::npos) << r.output;
  // A truth that does not cover the scans names its file and the first scan it misses.
  const std::string partial = dir + "/partial.csv";
  {
    std::ifstream in(dir + "/sim/ground_truth/trajectory.csv");
    std::ofstream part(partial);
    std::string line;
    for (int i = 0; i < 10 && std::getline(in, line); ++i) part << line << '\n';
  }
  r = storey::test::runCommand(storey + " slam " + bag + " --truth " + partial + " --output " +
                               dir + "/slam");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(partial + ": no pose of robot 'robot1' at or around t="),
            std::string::npos)
      << r.output;
}

// A bag of two robots: storey slam needs to be told which; scans of the chosen robot that
// its odometry does not cover are dropped, counted, and the rest is mapped.
TEST_F(SlamCommand, TakesOneRobotOfSeveralAndDropsScansWithoutOdometry) {
  const std::string dir = storey::test::makeTempDir("slam_cmd");
  const std::string bag = dir + "/two_robots";
  {
    storey::runtime::SensorBagWriter writer(bag);
    for (int i = 0; i < 40; ++i) {
      const double t = 0.25 * i;
      for (const std::string robot : {"a", "b"}) {
        storey::sensor::LaserScan scan;  // a square room 4 m across, the robot at its centre
        scan.stamp = t;
        scan.angle_min = -M_PI;
        scan.angle_increment = 2.0 * M_PI / 360.0;
        scan.range_min = 0.1;
        scan.range_max = 10.0;
        for (int k = 0; k < 360; ++k) {
          const double a = scan.angle(k);
          scan.ranges.push_back(
              static_cast<float>(2.0 / std::max(std::abs(std::cos(a)), std::abs(std::sin(a)))));
        }
        writer.write(robot, scan);
        if (t > 5.0) continue;  // odometry stops after 5 s; scans go on to 9.75 s
        storey::sensor::OdometrySample odom;
        odom.stamp = t;
        writer.write(robot, odom);
      }
    }
  }
  storey::test::CommandResult r = storey::test::runCommand(storey + " slam " + bag);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(bag + " holds robots a, b: name one with --robot"), std::string::npos)
      << r.output;
  r = storey::test::runCommand(storey + " slam " + bag + " --robot b --output " + dir +
                               "/slam --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  // Scans up to 5.5 s are within 0.5 s of the last odometry (5.0 s): 23 mapped, 17 dropped.
  EXPECT_NE(r.output.find("17 scans had no odometry within 0.5 s and were dropped"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("scans: 23 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(robot b)"), std::string::npos) << r.output;
  // The floor mapper's file's max_odometry_gap (2 s here) holds for storey slam too: scans
  // up to 7 s are mapped, 29, and 11 dropped.
  const std::string patient = dir + "/patient.yaml";
  ASSERT_EQ(copyReplacingLines(config, patient, "max_odometry_gap:", "max_odometry_gap: 2.0"), 1u);
  r = storey::test::runCommand(storey + " slam " + bag + " --robot b --config " + patient +
                               " --output " + dir + "/slam_patient --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("11 scans had no odometry within 2 s and were dropped"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("scans: 29 "), std::string::npos) << r.output;
}

// A CARMEN log converted into a bag (`storey convert`) keeps its scans' stamps, so the log's
// poses are the bag's reference: --reference matches them by stamp. Shifted stamps match
// nothing and are refused naming the log.
// A 6 m square room with a pillar; the robot drives a circle of radius 1.5 m about its
// centre, a 180-beam laser forward: 60 FLASER lines 0.2 s apart from t = 10 s, each with the
// true pose. With `odom_lines`, ODOM lines of the true pose halfway between the scans.
void writeRoomLog(const std::string& path, bool odom_lines) {
  std::ofstream file(path);
  file << std::fixed << std::setprecision(4);
  auto pose_at = [](double t) {
    const double phi = 2.0 * M_PI * (t - 10.0) / 12.0;
    return std::array<double, 3>{1.5 * std::cos(phi), 1.5 * std::sin(phi), phi + M_PI / 2.0};
  };
  for (int k = 0; k < 60; ++k) {
    const double stamp = 10.0 + 0.2 * k;
    if (odom_lines) {
      const double t = stamp + 0.1;
      const auto p = pose_at(t);
      file << "ODOM " << p[0] << ' ' << p[1] << ' ' << p[2] << " 0.785 0.524 0 " << t << " host "
           << t << '\n';
    }
    const auto [x, y, theta] = pose_at(stamp);
    file << "FLASER 180";
    for (int b = 0; b < 180; ++b) {
      const double a = theta - M_PI / 2.0 + b * M_PI / 180.0;
      const double dx = std::cos(a), dy = std::sin(a);
      double range = 1e9;  // nearest of the four walls at +-3 m...
      if (std::abs(dx) > 1e-9) range = std::min(range, ((dx > 0 ? 3.0 : -3.0) - x) / dx);
      if (std::abs(dy) > 1e-9) range = std::min(range, ((dy > 0 ? 3.0 : -3.0) - y) / dy);
      // ...and a pillar of radius 0.3 m at (0.5, 0.2), so the room has no symmetry.
      const double px = x - 0.5, py = y - 0.2, along = -(px * dx + py * dy);
      const double miss = px * px + py * py - along * along;
      if (along > 0.0 && miss < 0.09) range = std::min(range, along - std::sqrt(0.09 - miss));
      file << ' ' << range;
    }
    file << ' ' << x << ' ' << y << ' ' << theta << ' ' << x << ' ' << y << ' ' << theta << ' '
         << stamp << " host " << stamp << '\n';
  }
}

TEST_F(SlamCommand, ABagConvertedFromALogIsComparedWithTheLogsPoses) {
  const std::string dir = storey::test::makeTempDir("slam_cmd");
  const std::string log = dir + "/room.log";
  writeRoomLog(log, false);
  storey::test::CommandResult r =
      storey::test::runCommand(storey + " convert " + log + " " + dir + "/bag");
  ASSERT_EQ(r.status, 0) << r.output;
  r = storey::test::runCommand(storey + " slam " + dir + "/bag --reference " + log + " --output " +
                               dir + "/slam --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  // The bag's odometry is the log's poses: exact, and the map keeps to it.
  EXPECT_NE(r.output.find("odometry nearby pairs: 59  translation 0.0000"), std::string::npos)
      << r.output;
  const double nearby = translation(r.output, "slam", "nearby");
  ASSERT_GE(nearby, 0.0) << r.output;
  EXPECT_LT(nearby, 0.01) << r.output;

  r = storey::test::runCommand(storey + " convert " + log + " " + dir +
                               "/shifted --stamp-offset 100");
  ASSERT_EQ(r.status, 0) << r.output;
  r = storey::test::runCommand(storey + " slam " + dir + "/shifted --reference " + log +
                               " --output " + dir + "/slam2");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(log + ": no pose of robot 'robot' at or around t=110.000 s"),
            std::string::npos)
      << r.output;
  r = storey::test::runCommand(storey + " slam " + dir + "/bag --reference " + log + " --truth " +
                               log);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--truth or --reference"), std::string::npos) << r.output;
}

// A log's ODOM lines, interpolated at each scan's stamp as the floor_mapper pairs them live
// (--odometry stream), against its laser lines' poses as the reference.
TEST_F(SlamCommand, PairsALogsScansWithItsOdomLines) {
  const std::string dir = storey::test::makeTempDir("slam_cmd");
  const std::string log = dir + "/room.log";
  writeRoomLog(log, true);
  storey::test::CommandResult r =
      storey::test::runCommand(storey + " slam " + log + " --odometry stream --reference " + log +
                               " --output " + dir + "/slam --quiet");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("odometry: the log's ODOM lines at each scan's stamp (60 samples)"),
            std::string::npos)
      << r.output;
  // Interpolated on a chord of the circle: 1.5 m * (1 - cos 3 deg) inside the arc, at every scan
  // alike.
  const double odometry_nearby = translation(r.output, "odometry", "nearby");
  ASSERT_GE(odometry_nearby, 0.0) << r.output;
  EXPECT_LT(odometry_nearby, 0.002) << r.output;
  const double nearby = translation(r.output, "slam", "nearby");
  ASSERT_GE(nearby, 0.0) << r.output;
  EXPECT_LT(nearby, 0.01) << r.output;

  const std::string without = dir + "/no_odom.log";
  writeRoomLog(without, false);
  r = storey::test::runCommand(storey + " slam " + without + " --odometry stream --output " + dir +
                               "/slam2");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find(without + " has no ODOM lines for --odometry stream"), std::string::npos)
      << r.output;
}

}  // namespace
