#include "storey/building/robot_locations.h"

#include <gtest/gtest.h>

#include "building_runs.h"

namespace storey::building {
namespace {

using geometry::Pose2;

TEST(RobotLocations, EachRobotIsAtItsNewestNodeWithItsOdometryFrame) {
  const Pose2 frame1(3.0, -2.0, 0.4), odom_a(1.0, 2.0, 0.3), odom_b(-4.0, 0.5, -1.0);
  std::vector<Pose2> truth0, truth1, truth2;
  BuildingGraph building;
  building.upsertFloorGraph(makeRun("a", 0, 0, 0.0, 0.0, Pose2(), odom_a, &truth0));
  // Robot a rode to floor 1 later; its graph there is placed by three constraints.
  building.upsertFloorGraph(makeRun("a", 1, 1, 3.5, 100.0, frame1, odom_a, &truth1));
  building.upsertFloorGraph(makeRun("b", 2, 0, 0.0, 50.0, Pose2(), odom_b, &truth2));
  int id = 0;
  for (int k : {1, 3, 5}) {
    for (int graph : {1, 2})
      building.addConstraint(exactConstraint(id++, 0, k, graph, k, truth0[k],
                                             graph == 1 ? truth1[k] : truth2[k],
                                             graph == 1 ? 3.5 : 0.0));
  }
  const BuildingSolution solution = building.optimize();
  const auto locations = robotLocations(building, solution);
  ASSERT_EQ(locations.size(), 2u);
  const RobotLocation& a = locations[0];
  EXPECT_EQ(a.robot, "a");
  EXPECT_EQ(a.graph_id, 1);
  EXPECT_EQ(a.floor_id, 1);
  EXPECT_DOUBLE_EQ(a.floor_height, 3.5);
  EXPECT_DOUBLE_EQ(a.stamp, 105.0);
  EXPECT_TRUE(a.aligned);
  EXPECT_NEAR((a.pose.translation() - truth1.back().translation()).norm(), 0.0, 1e-6);
  // The odometry frame in the building: composing it with the robot's odometry gives
  // where the robot is.
  EXPECT_NEAR((a.odomInBuilding().translation() - odom_a.translation()).norm(), 0.0, 1e-6);
  EXPECT_NEAR(std::remainder(a.odomInBuilding().theta() - odom_a.theta(), 2 * M_PI), 0.0, 1e-6);
  const RobotLocation& b = locations[1];
  EXPECT_EQ(b.robot, "b");
  EXPECT_EQ(b.floor_id, 0);
  EXPECT_NEAR((b.odomInBuilding().translation() - odom_b.translation()).norm(), 0.0, 1e-6);
}

TEST(RobotLocations, NoGraphsNoLocations) {
  BuildingGraph building;
  EXPECT_TRUE(robotLocations(building, building.optimize()).empty());
}

}  // namespace
}  // namespace storey::building
