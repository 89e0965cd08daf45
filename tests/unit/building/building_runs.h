// Floor graphs for the building output tests: straight runs of one robot on one floor,
// placed exactly in the building.
#pragma once

#include <string>
#include <vector>

#include "storey/building/building_graph.h"

namespace storey::building {

using geometry::Pose2;

// A straight run of nodes of `robot` on one floor, placed exactly in the building by
// `frame`; the robot's odometry frame lies at `odom_in_building`.
inline floor::FloorGraph makeRun(const std::string& robot, int graph_id, int floor_id,
                                 double height, double first_stamp, const Pose2& frame,
                                 const Pose2& odom_in_building, std::vector<Pose2>* truth) {
  floor::FloorGraph g;
  g.robot = robot;
  g.graph_id = graph_id;
  g.floor_id = floor_id;
  g.floor_height = height;
  for (int i = 0; i < 6; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.stamp = first_stamp + i;
    n.pose = Pose2(0.5 * i, 0.1 * i * i, 0.05 * i);
    truth->push_back(frame * n.pose);
    n.odometry = odom_in_building.inverse() * truth->back();
    g.nodes.push_back(n);
    if (i > 0) {
      floor::FloorEdge e;
      e.from = i - 1;
      e.to = i;
      e.measurement = g.nodes[i - 1].pose.between(n.pose);
      e.information = Eigen::Vector3d(100, 100, 400).asDiagonal();
      g.edges.push_back(e);
    }
  }
  return g;
}

}  // namespace storey::building
