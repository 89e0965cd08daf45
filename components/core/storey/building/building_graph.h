// The building graph: every floor graph (one per robot and floor) and the inter-floor
// constraints between them, optimised as one pose graph. Its result places each floor
// graph in the building frame (a planar transform plus the floor's height).
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"
#include "storey/graph/optimizer.h"
#include "storey/graph/pose_graph.h"

namespace storey::building {

// A constraint between a node of one floor graph and a node of another:
// `relative` is the pose of (graph_to, node_to) in the frame of (graph_from, node_from),
// once both floors are stacked in the building frame; dz is the height difference.
struct InterGraphConstraint {
  int id = 0;
  int graph_from = 0;
  int node_from = 0;
  int graph_to = 0;
  int node_to = 0;
  geometry::Pose2 relative;
  double dz = 0.0;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
};

// Withdraws every constraint between these two nodes (the matcher no longer stands behind
// it). Constraints are named by their nodes, not their ids: ids restart with the matcher.
struct ConstraintRetraction {
  int graph_from = 0;
  int node_from = 0;
  int graph_to = 0;
  int node_to = 0;
  std::string reason;
  bool retracts(const InterGraphConstraint& c) const {
    return c.graph_from == graph_from && c.node_from == node_from && c.graph_to == graph_to && c.node_to == node_to;
  }
};

// The building graph's solver: the keys under `building.optimizer` in the shipped
// config/graph_server.yaml set on the optimiser's own defaults.
graph::OptimizerOptions shippedBuildingOptimizer();

struct BuildingGraphOptions {
  graph::OptimizerOptions optimizer = shippedBuildingOptimizer();
};
BuildingGraphOptions readBuildingGraphOptions(const common::ConfigNode& node);

struct FloorPlacement {
  int graph_id = 0;
  int floor_id = 0;
  std::string robot;
  geometry::Pose2 transform;  // floor graph frame -> building frame
  double height = 0.0;
  bool aligned = false;  // connected to the reference floor graph by constraints
  // Not aligned, but placed where a robot's odometry through a floor change puts it;
  // neither: left in its own frame.
  bool placed_by_ride = false;
};

struct BuildingSolution {
  std::vector<FloorPlacement> placements;  // by graph id order
  // Optimised pose of every node in the building frame, keyed by (graph, node).
  std::map<std::pair<int, int>, geometry::Pose2> poses;
  double initial_chi2 = 0.0;
  double final_chi2 = 0.0;
  int iterations = 0;
  int reference_graph = -1;
  const FloorPlacement* placement(int graph_id) const;
};

class BuildingGraph {
 public:
  explicit BuildingGraph(const BuildingGraphOptions& options = {});

  // Adds or replaces a floor graph (all its nodes, edges and local poses).
  void upsertFloorGraph(const floor::FloorGraph& graph);
  // The floor graph with this id for changing in place (created empty if absent), so an
  // update need not copy the graph it extends.
  floor::FloorGraph& floorGraphForUpdate(int graph_id);
  // Throws std::invalid_argument naming the constraint when it refers to an unknown
  // graph or node, or its values are not finite.
  void addConstraint(const InterGraphConstraint& constraint);
  void removeLastConstraint() { constraints_.pop_back(); }
  // Removes the constraints `retraction` names; returns how many there were.
  std::size_t retractConstraint(const ConstraintRetraction& retraction);

  const std::map<int, floor::FloorGraph>& floorGraphs() const { return graphs_; }
  const std::vector<InterGraphConstraint>& constraints() const { return constraints_; }
  bool empty() const { return graphs_.empty(); }

  // Optimises all floor graphs and constraints together. The reference (gauge) is the
  // lowest graph id with constraints (or the lowest id); graphs that no constraint joins
  // to the reference are reported as not aligned, and placed where a robot's odometry
  // through a floor change (its last node in a placed graph, its next in one of theirs)
  // puts them, the paper's baseline; with no such change, in their own frame.
  BuildingSolution optimize();
  // The pose graph of the last optimize().
  const graph::PoseGraph& poseGraph() const { return pose_graph_; }
  // The building's pose graph with the poses of `solution` (e.g. for g2o export).
  graph::PoseGraph poseGraphAt(const BuildingSolution& solution) const;

  // Node ids of the building's pose graph: floor-graph id x kGraphIdStride + node id.
  static constexpr graph::NodeId kGraphIdStride = 1000000;
  static graph::NodeId globalId(int graph_id, int node_id) {
    return static_cast<graph::NodeId>(graph_id) * kGraphIdStride + node_id;
  }

 private:
  void addEdges(graph::PoseGraph& pose_graph) const;
  // Moves each set of graphs the constraints join (component_root: graph -> the set's
  // root) that is not the reference's to where a floor change from a placed set puts it;
  // returns the roots of the sets placed (the reference's included).
  std::set<int> placeByFloorChanges(const std::map<int, int>& component_root, int reference,
                                    std::map<int, geometry::Pose2>* transform) const;

  BuildingGraphOptions options_;
  std::map<int, floor::FloorGraph> graphs_;
  std::vector<InterGraphConstraint> constraints_;
  graph::PoseGraph pose_graph_;
  BuildingSolution solution_;
};

// Least-squares rigid transform T with T * local[i] ≈ global[i] (positions and headings).
geometry::Pose2 fitRigidTransform(const std::vector<geometry::Pose2>& local,
                                  const std::vector<geometry::Pose2>& global);

}  // namespace storey::building
