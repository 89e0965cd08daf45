// Where each robot is in the building after an optimisation: its newest node, on the
// floor of that node's graph. From it the live outputs a ROS 2 robot expects: the
// building -> odom transform (REP 105's map -> odom), which composed with the robot's own
// odom -> base_link places it between optimisations, and the pose with its floor.
#pragma once

#include <string>
#include <vector>

#include "storey/building/building_graph.h"

namespace storey::building {

struct RobotLocation {
  std::string robot;
  double stamp = 0.0;  // the node's (sensor time)
  int graph_id = 0;
  int floor_id = 0;
  double floor_height = 0.0;  // m, the floor graph's
  bool aligned = false;       // its floor graph is joined to the reference by constraints
  geometry::Pose2 pose;       // building frame
  geometry::Pose2 odometry;   // the robot's raw odometry pose at that node
  // The robot's odometry frame in the building frame.
  geometry::Pose2 odomInBuilding() const { return pose * odometry.inverse(); }
};

// One per robot with a node in `solution`, sorted by robot name.
std::vector<RobotLocation> robotLocations(const BuildingGraph& building,
                                          const BuildingSolution& solution);

}  // namespace storey::building
