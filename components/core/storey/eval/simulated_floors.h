// Floor graphs from a simulator run, with their true frames: the test bed for the floor
// matcher (scenario tests, benchmark, `storey match <building.yaml>`). Each robot's scans
// on one floor (not inside a shaft, not during a transit) become one floor graph whose
// nodes are taken every `node_distance` metres or `node_angle` radians of odometry. Node
// poses are the true poses expressed in a random frame per graph (a mapped floor has an
// arbitrary origin), so the matcher must find the alignment; the odometry is the
// simulator's noisy odometry.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "storey/floor/floor_graph.h"
#include "storey/geometry/pose2.h"
#include "storey/matching/constraint_judgement.h"
#include "storey/matching/floor_matcher.h"
#include "storey/sim/simulator.h"

namespace storey::eval {

struct SimulatedFloorsOptions {
  double node_distance = 0.3;         // metres of odometry between nodes
  double node_angle = 0.3;            // radians
  double frame_translation = 20.0;    // each graph's frame is offset uniformly up to this (m)
  bool random_frame_rotation = true;  // and rotated uniformly (else only translated)
  int min_nodes = 10;                 // graphs with fewer nodes are dropped
  std::uint64_t seed = 1;
};

struct SimulatedFloors {
  std::vector<floor::FloorGraph> graphs;
  std::vector<geometry::Pose2> frames;  // graph frame in the building frame (the truth)
  // Mapped graphs (a `storey map` journal) are estimates, not true poses in a true frame:
  // per graph (same order), node id -> the node's true pose in the building frame. Then
  // `frames` is only a rigid fit, and constraints are judged by these instead.
  std::vector<std::map<int, geometry::Pose2>> node_truth;
};

// The true pose of node `node` of graph `graph_index` in the building frame: from
// node_truth when it has the node, else the graph's true frame times the node's pose.
geometry::Pose2 trueNodePose(const SimulatedFloors& floors, std::size_t graph_index,
                             const floor::FloorNode& node);

SimulatedFloors floorGraphsFromSimulation(const sim::Simulation& simulation,
                                          const SimulatedFloorsOptions& options);

// How far an accepted constraint is from the truth, and whether that is wrong for what
// its information claims: node k as the constraint places it in the frame of node q,
// against their true poses (trueNodePose).
matching::ConstraintJudgement judgeConstraint(const matching::InterFloorConstraint& constraint,
                                              const SimulatedFloors& floors,
                                              const matching::WrongConstraintLimits& limits = {});

// How far an alignment of graph `graph_id` in graph `reference_graph_id` is from the
// truth, at the centroid of the graph's nodes.
struct ConstraintError {
  double translation = 0.0;  // metres
  double rotation = 0.0;     // radians
};
ConstraintError alignmentError(const geometry::Pose2& alignment, int reference_graph_id,
                               int graph_id, const SimulatedFloors& floors);

}  // namespace storey::eval
