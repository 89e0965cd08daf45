// Properties of the shipped scenarios beyond loading: fleets, rotated floors, stairs.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::sim {
namespace {

std::string scenarioPath(const std::string& name) {
  return test::sourceDir() + "/config/buildings/" + name + ".yaml";
}

TEST(Fleet, ARobotsDataDoesNotDependOnTheOtherRobots) {
  const Scenario scenario = loadScenario(scenarioPath("fleet"));
  ASSERT_EQ(scenario.robots.size(), 3u);
  const Simulation all = simulate(scenario, 11);
  SimulateOptions only;
  only.seed = 11;
  only.robots = {"robot2"};
  const Simulation one = simulate(scenario, only);
  ASSERT_EQ(all.robots.size(), 3u);
  ASSERT_EQ(one.robots.size(), 1u);
  const RobotRun& a = all.robots[1];
  const RobotRun& b = one.robots[0];
  EXPECT_EQ(a.name, "robot2");
  ASSERT_EQ(a.scans.size(), b.scans.size());
  for (std::size_t i = 0; i < a.scans.size(); ++i) ASSERT_EQ(a.scans[i].ranges, b.scans[i].ranges);
  ASSERT_EQ(a.pressure.size(), b.pressure.size());
  for (std::size_t i = 0; i < a.pressure.size(); ++i)
    ASSERT_EQ(a.pressure[i].pascal, b.pressure[i].pascal);
  EXPECT_EQ(a.odometry.back().pose.x(), b.odometry.back().pose.x());
  // Staggered starts: robot2 starts 5 s in, robot3 10 s in.
  EXPECT_DOUBLE_EQ(all.robots[1].scans.front().stamp, 5.0);
  EXPECT_DOUBLE_EQ(all.robots[2].scans.front().stamp, 10.0);
  SimulateOptions unknown;
  unknown.robots = {"robot9"};
  EXPECT_THROW(simulate(scenario, unknown), std::invalid_argument);
}

TEST(Tower10, FloorsStayStackedUnderTheirShaftsAndRidesTurnTheOdometry) {
  // As in the paper, the rotational error is in the robot's estimate (a heading error per
  // elevator ride), not in the building.
  const Scenario scenario = loadScenario(scenarioPath("tower10"));
  const Building& b = scenario.building;
  ASSERT_EQ(b.floors.size(), 10u);
  for (const Floor& floor : b.floors) EXPECT_EQ(floor.frame.theta(), 0.0) << floor.id;
  ASSERT_EQ(scenario.robots.size(), 1u);
  EXPECT_GT(scenario.robots[0].model.odometry.elevator_heading_sigma, 0.0);
}

TEST(FloorRotation, TurnsFloorsAboutTheElevatorAndTheScansSeeIt) {
  // tower10 with its floors turned (the option no bundled scenario uses).
  std::ifstream in(scenarioPath("tower10"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string anchor = "building:\n  name: tower10\n";
  ASSERT_NE(text.find(anchor), std::string::npos);
  text.insert(text.find(anchor) + anchor.size(),
              "  floor_rotation: {sigma_deg: 1.0, seed: 2010}\n");
  const std::string robots_dir = std::string(STOREY_SOURCE_DIR) + "/config/robots";
  const Scenario scenario = loadScenarioString(text, "tower10-turned", robots_dir);
  const Building& b = scenario.building;
  ASSERT_EQ(b.floors.size(), 10u);
  EXPECT_EQ(b.floors[0].frame.theta(), 0.0);
  double sum_sq = 0.0;
  const Eigen::Vector2d pivot = b.shaft("E").center;
  for (std::size_t i = 1; i < b.floors.size(); ++i) {
    const double angle = b.floors[i].frame.theta();
    EXPECT_NE(angle, 0.0);
    EXPECT_LT(std::abs(angle), 4.0 * 3.14159265 / 180.0);  // 4 sigma
    sum_sq += angle * angle;
    // Turned about the elevator centre: the pivot stays put.
    EXPECT_NEAR((b.floors[i].frame.transformPoint(pivot) - pivot).norm(), 0.0, 1e-9);
  }
  EXPECT_GT(std::sqrt(sum_sq / 9.0), 0.2 * 3.14159265 / 180.0);
  // The same floor-frame pose sees the same ranges on F0 and on a turned floor when the
  // pose turns with the floor; it sees different ranges when it does not.
  LaserOptions laser;
  laser.beams = 90;
  const geometry::Pose2 local(9.0, 8.0, 0.3);
  const auto f0 = castScan(floorObstacles(b, 0), laser, b.floors[0].frame * local);
  const auto f1_frame_pose = castScan(floorObstacles(b, 1), laser, b.floors[1].frame * local);
  const auto f1_building_pose = castScan(floorObstacles(b, 1), laser, local);
  int same = 0, different = 0;
  for (std::size_t i = 0; i < f0.size(); ++i) {
    if (!f0.isReturn(i) || !f1_frame_pose.isReturn(i) || !f1_building_pose.isReturn(i)) continue;
    same += std::abs(f0.ranges[i] - f1_frame_pose.ranges[i]) < 1e-3;
    different += std::abs(f0.ranges[i] - f1_building_pose.ranges[i]) > 0.01;
  }
  EXPECT_GT(same, 30);  // F1 differs from F0 only in furniture and a few walls
  EXPECT_GT(different, 10);
}

TEST(Stairs, HeightRisesSteadilyOnTheFlightsAndTheWellIsAllTheLaserSees) {
  const Scenario scenario = loadScenario(scenarioPath("corridors3"));
  const Simulation run = simulate(scenario, 3);
  const RobotRun& robot = run.robots[0];
  ASSERT_GE(robot.transits.size(), 1u);
  const Transit& climb = robot.transits[0];
  EXPECT_EQ(climb.mode, "stairs");
  EXPECT_EQ(climb.odometry_heading_error, 0.0);
  double previous = -1.0;
  int inside = 0;
  for (std::size_t i = 0; i < robot.truth.size(); ++i) {
    const TruthSample& t = robot.truth[i];
    if (t.stamp < climb.start || t.stamp > climb.end) continue;
    EXPECT_GE(t.z, previous - 1e-12);  // never goes down while climbing up
    EXPECT_GE(t.z, 0.0);
    EXPECT_LE(t.z, 3.2 + 1e-9);
    previous = t.z;
    ++inside;
    // A 2.5 m x 2.4 m well: no return is longer than its diagonal.
    for (std::size_t k = 0; k < robot.scans[i].size(); ++k) {
      if (robot.scans[i].isReturn(k)) {
        EXPECT_LT(robot.scans[i].ranges[k], 3.5);
      }
    }
  }
  EXPECT_GT(inside, 20);
  const MotionState end = robot.trajectory.at(climb.end + 0.01);
  EXPECT_NEAR(end.z, 3.2, 1e-9);
  EXPECT_EQ(end.floor, 1);
}

}  // namespace
}  // namespace storey::sim
