#include "storey/eval/simulated_floors.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>

namespace storey::eval {

using geometry::Pose2;

namespace {

// Odometry pose at `stamp`, interpolated between the bracketing samples.
Pose2 odometryAt(const std::vector<sensor::OdometrySample>& odom, double stamp) {
  if (odom.empty()) return Pose2();
  auto it = std::lower_bound(odom.begin(), odom.end(), stamp,
                             [](const sensor::OdometrySample& s, double t) { return s.stamp < t; });
  if (it == odom.begin()) return it->pose;
  if (it == odom.end()) return odom.back().pose;
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double span = b.stamp - a.stamp;
  const double t = span > 0 ? (stamp - a.stamp) / span : 0.0;
  return geometry::interpolate(a.pose, b.pose, t);
}

const floor::FloorGraph* findGraph(const SimulatedFloors& floors, int graph_id,
                                   std::size_t* index) {
  for (std::size_t i = 0; i < floors.graphs.size(); ++i) {
    if (floors.graphs[i].graph_id == graph_id) {
      *index = i;
      return &floors.graphs[i];
    }
  }
  throw std::invalid_argument("no simulated floor graph with id " + std::to_string(graph_id));
}

}  // namespace

SimulatedFloors floorGraphsFromSimulation(const sim::Simulation& simulation,
                                          const SimulatedFloorsOptions& options) {
  SimulatedFloors out;
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int next_id = 0;
  for (const sim::RobotRun& run : simulation.robots) {
    std::map<int, floor::FloorGraph> graphs;  // by floor index
    std::map<int, Pose2> last_odometry;
    for (std::size_t s = 0; s < run.scans.size() && s < run.truth.size(); ++s) {
      const sim::TruthSample& truth = run.truth[s];
      const double stamp = run.scans[s].stamp;
      bool moving_between_floors = false;
      for (const auto& transit : run.transits)
        if (stamp >= transit.start && stamp <= transit.end) moving_between_floors = true;
      if (moving_between_floors) continue;
      const sim::MotionState state = run.trajectory.at(stamp);
      if (state.scene >= 0 && state.scene < static_cast<int>(run.trajectory.scenes().size()) &&
          run.trajectory.scenes()[state.scene].kind == sim::SceneKey::Kind::kInsideShaft)
        continue;
      const Pose2 odom = odometryAt(run.odometry, stamp);
      auto last = last_odometry.find(truth.floor);
      if (last != last_odometry.end()) {
        const Pose2 delta = last->second.between(odom);
        if (delta.translation().norm() < options.node_distance &&
            std::abs(delta.theta()) < options.node_angle)
          continue;
      }
      last_odometry[truth.floor] = odom;
      floor::FloorGraph& g = graphs[truth.floor];
      floor::FloorNode node;
      node.id = static_cast<int>(g.nodes.size());
      node.stamp = stamp;
      node.pose = truth.pose;  // building frame for now
      node.odometry = odom;
      node.first_pose = odom;  // no front end here: odometry is the first estimate
      node.scan = run.scans[s];
      g.nodes.push_back(std::move(node));
    }
    for (auto& [floor_index, g] : graphs) {
      if (static_cast<int>(g.nodes.size()) < options.min_nodes) continue;
      const Pose2 frame(options.frame_translation * unit(rng),
                        options.frame_translation * unit(rng),
                        options.random_frame_rotation ? M_PI * unit(rng) : 0.0);
      g.robot = run.name;
      g.graph_id = next_id++;
      g.floor_id = floor_index;
      g.floor_height = simulation.building.floors.at(floor_index).height;
      const Pose2 inverse = frame.inverse();
      for (auto& node : g.nodes) node.pose = inverse * node.pose;
      for (std::size_t i = 1; i < g.nodes.size(); ++i) {
        floor::FloorEdge e;
        e.from = g.nodes[i - 1].id;
        e.to = g.nodes[i].id;
        e.measurement = g.nodes[i - 1].pose.between(g.nodes[i].pose);
        g.edges.push_back(e);
      }
      out.graphs.push_back(std::move(g));
      out.frames.push_back(frame);
    }
  }
  return out;
}

matching::ConstraintJudgement judgeConstraint(const matching::InterFloorConstraint& c,
                                              const SimulatedFloors& floors,
                                              const matching::WrongConstraintLimits& limits) {
  std::size_t ri = 0, gi = 0;
  const floor::FloorGraph* ref = findGraph(floors, c.reference_graph_id, &ri);
  const floor::FloorGraph* g = findGraph(floors, c.graph_id, &gi);
  const floor::FloorNode* q = ref->findNode(c.reference_node_id);
  const floor::FloorNode* k = g->findNode(c.node_id);
  if (!q || !k) throw std::invalid_argument("constraint names a node that does not exist");
  const Pose2 truth = trueNodePose(floors, ri, *q).between(trueNodePose(floors, gi, *k));
  return matching::judgeConstraint(c.measurement, truth, c.information, limits);
}

Pose2 trueNodePose(const SimulatedFloors& floors, std::size_t graph_index,
                   const floor::FloorNode& node) {
  if (graph_index < floors.node_truth.size()) {
    const auto it = floors.node_truth[graph_index].find(node.id);
    if (it != floors.node_truth[graph_index].end()) return it->second;
  }
  return floors.frames.at(graph_index) * node.pose;
}

ConstraintError alignmentError(const Pose2& alignment, int reference_graph_id, int graph_id,
                               const SimulatedFloors& floors) {
  std::size_t ri = 0, gi = 0;
  findGraph(floors, reference_graph_id, &ri);
  const floor::FloorGraph* g = findGraph(floors, graph_id, &gi);
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& n : g->nodes) centroid += n.pose.translation();
  if (!g->nodes.empty()) centroid /= static_cast<double>(g->nodes.size());
  const Pose2 truth = floors.frames[ri].inverse() * floors.frames[gi];
  const Pose2 at(centroid.x(), centroid.y(), 0.0);
  const Pose2 a = alignment * at, b = truth * at;
  return {(a.translation() - b.translation()).norm(),
          std::abs(geometry::angleDiff(a.theta(), b.theta()))};
}

}  // namespace storey::eval
