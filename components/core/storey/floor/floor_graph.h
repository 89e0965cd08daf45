// A floor graph: one robot's pose graph of one floor (the paper's g_i). Each node keeps
// its pose and its scan (n_k = <p_k, z_k>) and the odometry pose at that moment, so any
// floor's scans can later be replayed, with their odometry, in another floor's map.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/sensor/laser_scan.h"

namespace storey::floor {

struct FloorNode {
  int id = 0;  // unique within its floor graph
  double stamp = 0.0;
  geometry::Pose2 pose;      // optimised pose in the floor graph's frame
  geometry::Pose2 odometry;  // raw odometry pose when the scan was taken
  // The pose the floor graph first gave the node, before optimisation moved it: the front
  // end's scan-matched odometry, which the matcher replays the scans with (the raw
  // odometry is noisier, and jumps where the floor is visited again after a ride).
  geometry::Pose2 first_pose;
  sensor::LaserScan scan;
};

enum class EdgeKind { kOdometry, kScanMatch, kLoopClosure };
const char* edgeKindName(EdgeKind kind);

struct FloorEdge {
  int from = 0;
  int to = 0;
  geometry::Pose2 measurement;  // pose of `to` in the frame of `from`
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  EdgeKind kind = EdgeKind::kOdometry;
};

struct FloorGraph {
  std::string robot;
  int graph_id = 0;  // unique per (robot, floor visit series); a floor visited twice is one graph
  int floor_id = 0;
  double floor_height = 0.0;
  std::vector<FloorNode> nodes;  // in creation (time) order
  std::vector<FloorEdge> edges;

  const FloorNode* findNode(int id) const;
  // Index of the node nearest to a point (in this graph's frame) among the first `count`
  // (all by default); -1 when there are none.
  int nearestNodeIndex(const Eigen::Vector2d& point,
                       std::size_t count = std::numeric_limits<std::size_t>::max()) const;
  // The same among the nodes [first, end).
  int nearestNodeIndex(const Eigen::Vector2d& point, std::size_t first, std::size_t end) const;
};

// Floor-graph ids are keys across the fleet: an update from `robot` for `graph`, which
// already holds another robot's nodes, is rejected (std::invalid_argument naming both)
// rather than merged.
void requireSameRobot(const FloorGraph& graph, const std::string& robot);

// The occupancy map of a floor graph: every node's scan inserted at its pose.
grid::OccupancyGrid renderFloorMap(const FloorGraph& graph, const grid::OccupancyGridOptions& options);

// The returns of nodes [first, last) in the floor's frame, closer than `max_range` to the
// sensor (0: the scan's range_max, as OccupancyGridOptions::max_insert_range).
std::vector<Eigen::Vector2d> floorPoints(const FloorGraph& graph, std::size_t first, std::size_t last,
                                         double max_range);
// The same for the nodes `indices`.
std::vector<Eigen::Vector2d> floorPoints(const FloorGraph& graph, const std::vector<std::size_t>& indices,
                                         double max_range);

// Where one robot changed floor graphs (a lift or stairs): its last node in one graph and
// its next node, in the other (node stamps; the floor graphs of one robot and floor are
// one graph).
struct TransitLink {
  int from_graph = 0, from_node = 0;
  int to_graph = 0, to_node = 0;
};
std::vector<TransitLink> transitLinks(const std::vector<FloorGraph>& graphs);
std::vector<TransitLink> transitLinks(const std::vector<const FloorGraph*>& graphs);

}  // namespace storey::floor
