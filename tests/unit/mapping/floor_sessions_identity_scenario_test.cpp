// FloorSessions deciding an arrival the height alone does not: the floor whose map holds
// the arriving scans is the floor reached.
#include <gtest/gtest.h>

#include "bare_options.h"
#include "floor_sessions_world.h"
#include "storey/common/log.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;
using test::asymmetricFloor;
using test::legs;
using test::Robot;

// Maps floor 0 (asymmetricFloor) from (1, 8, 0) and floor 1 (officeWorld); ends on floor 1.
void mapTwoFloors(Robot& robot) {
  robot.drive(asymmetricFloor(), legs({{1, 8}, {14, 8}, {14, 4}, {8, 4}, {8, 1.5}, {2, 4}}, 0.0));
  robot.ride(1, 3.0, Pose2(1, 1, 0.5));
  robot.drive(test::officeWorld(), legs({{1, 1}, {4, 1}, {4, 4.5}, {10, 4.5}, {10, 3}}, 0.5));
}

floor::FloorEvent unsureArrival(double end, int chosen, double height, std::vector<int> candidates,
                                int new_floor_id) {
  floor::FloorEvent e;
  e.type = floor::FloorEventType::kTransitEnded;
  e.stamp = e.decided_at = end;
  e.floor_id = chosen;
  e.floor_height = height;
  e.candidate_floors = std::move(candidates);
  e.new_floor_id = new_floor_id;
  e.new_floor_height = height;
  return e;
}

void rideUnsure(Robot& robot, const floor::FloorEvent& event, const Pose2& arrival) {
  robot.sessions.beginTransit();
  robot.arriveAt(arrival);
  floor::FloorEvent e = event;
  e.stamp = e.decided_at = robot.t;
  robot.sessions.endTransit(e);
}

TEST(FloorSessionsIdentity, TheFloorWhoseMapHoldsTheScansIsTheOneReached) {
  common::setLogLevel(common::LogLevel::kWarn);
  Robot robot(test::bareOptions(), Pose2(1, 8, 0));
  mapTwoFloors(robot);
  // The height says floor 1 (or a new one); the robot is back on floor 0, far from where it left.
  rideUnsure(robot, unsureArrival(0.0, 1, 3.0, {1, 0}, 2), Pose2(15, 3, M_PI));
  const double ride_end = robot.t;
  EXPECT_TRUE(robot.sessions.identifying());
  robot.drive(asymmetricFloor(), legs({{15, 3}, {11, 3}, {11, 5}, {6, 5}}, M_PI));
  EXPECT_FALSE(robot.sessions.identifying());
  const auto identities = robot.sessions.takeIdentities();
  ASSERT_EQ(identities.size(), 1u);
  EXPECT_EQ(identities[0].ride_end, ride_end);
  EXPECT_EQ(identities[0].floor_id, 0);
  EXPECT_TRUE(identities[0].localized);
  EXPECT_EQ(robot.sessions.currentFloor(), 0);
  EXPECT_EQ(robot.sessions.floors().size(), 2u);  // no third floor
  EXPECT_TRUE(robot.sessions.retired().empty());  // floor 0's own graph, resumed
  EXPECT_EQ(robot.sessions.stats().identified_by_map, 1u);
  robot.sessions.flush();
  const Pose2 last = robot.sessions.current().currentPose();
  const Pose2 expected = Pose2(1, 8, 0).between(robot.truth);
  EXPECT_LT((last.translation() - expected.translation()).norm(), 0.1);
}

TEST(FloorSessionsIdentity, AKnownFloorTheHeightDidNotChooseIsFound) {
  common::setLogLevel(common::LogLevel::kWarn);
  Robot robot(test::bareOptions(), Pose2(1, 8, 0));
  mapTwoFloors(robot);
  robot.ride(0, 0.0, Pose2(15, 3, M_PI));
  robot.drive(asymmetricFloor(), legs({{15, 3}, {11, 3}, {11, 5}}, M_PI));
  ASSERT_EQ(robot.sessions.currentFloor(), 0);
  robot.sessions.takeIdentities();
  // The height says floor 0 again (no new floor possible); the robot is on floor 1.
  rideUnsure(robot, unsureArrival(0.0, 0, 0.0, {0, 1}, -1), Pose2(10, 4, M_PI));
  robot.drive(test::officeWorld(), legs({{10, 4}, {4, 4}, {4, 1}, {1, 1}}, M_PI));
  const auto identities = robot.sessions.takeIdentities();
  ASSERT_EQ(identities.size(), 1u);
  EXPECT_EQ(identities[0].floor_id, 1);
  EXPECT_TRUE(identities[0].localized);
  EXPECT_EQ(robot.sessions.currentFloor(), 1);
  EXPECT_EQ(robot.sessions.floors().size(), 2u);
}

TEST(FloorSessionsIdentity, AFloorNoMapHoldsIsNewWhenTheHeightAllowsIt) {
  common::setLogLevel(common::LogLevel::kError);
  for (const int new_floor_id : {2, -1}) {
    Robot robot(test::bareOptions(), Pose2(1, 8, 0));
    mapTwoFloors(robot);
    // Neither floor: a long corridor (test::corridorWorld) the robot has never seen.
    rideUnsure(robot, unsureArrival(0.0, 1, 3.0, {1, 0}, new_floor_id), Pose2(2, 0, 0));
    robot.drive(test::corridorWorld(), legs({{2, 0}, {6, 0}}, 0.0));
    robot.sessions.flush();  // the input ends: decided with what was seen
    const auto identities = robot.sessions.takeIdentities();
    ASSERT_EQ(identities.size(), 1u);
    EXPECT_FALSE(identities[0].localized);
    if (new_floor_id >= 0) {
      // A floor never seen: a graph of its own, floor 1 untouched.
      EXPECT_EQ(identities[0].floor_id, 2);
      EXPECT_EQ(robot.sessions.currentFloor(), 2);
      EXPECT_EQ(robot.sessions.floors().size(), 3u);
      EXPECT_FALSE(robot.sessions.current().floorGraph().nodes.empty());
      EXPECT_TRUE(robot.sessions.retired().empty());
    } else {
      // No new floor is possible: the height's choice, in a new graph for the matcher.
      EXPECT_EQ(identities[0].floor_id, 1);
      EXPECT_EQ(robot.sessions.floors().size(), 2u);
      EXPECT_EQ(robot.sessions.retired().size(), 1u);
    }
  }
}

TEST(FloorSessionsIdentity, LeavingBeforeTheScansDecideKeepsTheHeightsChoice) {
  common::setLogLevel(common::LogLevel::kError);
  Robot robot(test::bareOptions(), Pose2(1, 8, 0));
  mapTwoFloors(robot);
  rideUnsure(robot, unsureArrival(0.0, 1, 3.0, {1, 0}, 2), Pose2(15, 3, M_PI));
  robot.drive(asymmetricFloor(), legs({{15, 3}, {14.6, 3}}, M_PI));  // two scans
  robot.sessions.decideIdentity();  // the detector waits (its next ride begins)
  const auto identities = robot.sessions.takeIdentities();
  ASSERT_EQ(identities.size(), 1u);
  EXPECT_FALSE(robot.sessions.identifying());
  EXPECT_FALSE(identities[0].localized);
  // Two scans localise nowhere, but floor 0's map fits them: not a floor never seen.
  EXPECT_EQ(identities[0].floor_id, 1);
}

}  // namespace
}  // namespace storey::mapping
