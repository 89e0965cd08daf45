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
// Exact odometry edges between consecutive nodes.
inline void chainEdges(floor::FloorGraph& g) {
  for (std::size_t i = 1; i < g.nodes.size(); ++i) {
    floor::FloorEdge e;
    e.from = g.nodes[i - 1].id;
    e.to = g.nodes[i].id;
    e.measurement = g.nodes[i - 1].pose.between(g.nodes[i].pose);
    e.information = Eigen::Vector3d(100, 100, 400).asDiagonal();
    g.edges.push_back(e);
  }
}

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
  }
  chainEdges(g);
  return g;
}

// An exact constraint between two nodes whose building poses are `from` and `to`.
inline InterGraphConstraint exactConstraint(int id, int graph_from, int node_from, int graph_to,
                                            int node_to, const Pose2& from, const Pose2& to,
                                            double dz) {
  InterGraphConstraint c;
  c.id = id;
  c.graph_from = graph_from;
  c.node_from = node_from;
  c.graph_to = graph_to;
  c.node_to = node_to;
  c.relative = from.between(to);
  c.dz = dz;
  c.information = Eigen::Vector3d(50, 50, 200).asDiagonal();
  return c;
}

}  // namespace storey::building
