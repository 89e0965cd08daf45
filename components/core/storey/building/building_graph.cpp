#include "storey/building/building_graph.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <set>
#include <sstream>
#include <stdexcept>

namespace storey::building {
namespace {

graph::EdgeKind toGraphKind(floor::EdgeKind kind) {
  switch (kind) {
    case floor::EdgeKind::kOdometry: return graph::EdgeKind::kOdometry;
    case floor::EdgeKind::kScanMatch: return graph::EdgeKind::kScanMatch;
    case floor::EdgeKind::kLoopClosure: return graph::EdgeKind::kLoopClosure;
  }
  return graph::EdgeKind::kOdometry;
}

}  // namespace

graph::OptimizerOptions shippedBuildingOptimizer() {
  namespace shipped_optimizer = shipped::graph_server::building::optimizer;
  namespace inter_floor = shipped_optimizer::robust::inter_floor;
  graph::OptimizerOptions o;
  o.algorithm = std::string(shipped_optimizer::algorithm) == "gn"
                    ? graph::Algorithm::kGaussNewton
                    : graph::Algorithm::kLevenbergMarquardt;
  o.max_iterations = shipped_optimizer::max_iterations;
  graph::RobustKernel& kernel = o.robust[static_cast<int>(graph::EdgeKind::kInterFloor)];
  kernel.type = graph::parseRobustKernel(inter_floor::kernel);
  kernel.delta = inter_floor::delta;
  return o;
}

BuildingGraphOptions readBuildingGraphOptions(const common::ConfigNode& node) {
  BuildingGraphOptions options;
  // The keys the shipped file lists; the solver's other settings are its own.
  const common::ConfigNode optimizer = node.child("optimizer");
  for (const std::string& key : optimizer.keys())
    if (key != "algorithm" && key != "max_iterations" && key != "robust")
      optimizer.fail(key,
                     "unknown key (building.optimizer takes algorithm, max_iterations, robust)");
  options.optimizer = graph::readOptimizerOptions(optimizer, options.optimizer);
  node.finish();
  return options;
}

const FloorPlacement* BuildingSolution::placement(int graph_id) const {
  for (const auto& p : placements)
    if (p.graph_id == graph_id) return &p;
  return nullptr;
}

BuildingGraph::BuildingGraph(const BuildingGraphOptions& options) : options_(options) {}

void BuildingGraph::upsertFloorGraph(const floor::FloorGraph& graph) { graphs_[graph.graph_id] = graph; }

floor::FloorGraph& BuildingGraph::floorGraphForUpdate(int graph_id) {
  floor::FloorGraph& graph = graphs_[graph_id];
  graph.graph_id = graph_id;
  return graph;
}

std::size_t BuildingGraph::retractConstraint(const ConstraintRetraction& retraction) {
  const std::size_t before = constraints_.size();
  constraints_.erase(std::remove_if(constraints_.begin(), constraints_.end(),
                                    [&](const InterGraphConstraint& c) { return retraction.retracts(c); }),
                     constraints_.end());
  return before - constraints_.size();
}

void BuildingGraph::addConstraint(const InterGraphConstraint& c) {
  auto fail = [&](const std::string& why) {
    std::ostringstream out;
    out << "inter-floor constraint " << c.id << " (graph " << c.graph_from << " node " << c.node_from
        << " -> graph " << c.graph_to << " node " << c.node_to << "): " << why;
    throw std::invalid_argument(out.str());
  };
  auto from = graphs_.find(c.graph_from), to = graphs_.find(c.graph_to);
  if (from == graphs_.end()) fail("unknown floor graph " + std::to_string(c.graph_from));
  if (to == graphs_.end()) fail("unknown floor graph " + std::to_string(c.graph_to));
  if (!from->second.findNode(c.node_from)) fail("unknown node " + std::to_string(c.node_from));
  if (!to->second.findNode(c.node_to)) fail("unknown node " + std::to_string(c.node_to));
  if (c.graph_from == c.graph_to) fail("both ends are in the same floor graph");
  if (!c.relative.isFinite() || !std::isfinite(c.dz)) fail("non-finite values");
  const std::string problem = graph::informationProblem(c.information);
  if (!problem.empty()) fail("information matrix: " + problem);
  constraints_.push_back(c);
}

BuildingSolution BuildingGraph::optimize() {
  BuildingSolution solution;
  if (graphs_.empty()) return solution;

  // Which graphs the constraints join together (breadth-first from each unvisited graph).
  std::map<int, std::vector<const InterGraphConstraint*>> incident;
  for (const auto& c : constraints_) {
    incident[c.graph_from].push_back(&c);
    incident[c.graph_to].push_back(&c);
  }
  int reference = graphs_.begin()->first;
  for (const auto& [id, graph] : graphs_)
    if (incident.count(id)) {
      reference = id;
      break;
    }
  solution.reference_graph = reference;

  // Initial transforms: keep the previous solution's where known, else chain constraints.
  std::map<int, geometry::Pose2> transform;
  std::map<int, int> component_root;
  std::vector<int> order{reference};
  for (const auto& [id, graph] : graphs_)
    if (id != reference) order.push_back(id);
  for (int root : order) {
    if (component_root.count(root)) continue;
    std::queue<int> frontier;
    frontier.push(root);
    component_root[root] = root;
    const FloorPlacement* previous = solution_.placement(root);
    transform[root] = previous ? previous->transform : geometry::Pose2();
    while (!frontier.empty()) {
      const int g = frontier.front();
      frontier.pop();
      for (const InterGraphConstraint* c : incident[g]) {
        const bool forward = c->graph_from == g;
        const int other = forward ? c->graph_to : c->graph_from;
        if (component_root.count(other)) continue;
        component_root[other] = root;
        const geometry::Pose2 from_local = graphs_.at(c->graph_from).findNode(c->node_from)->pose;
        const geometry::Pose2 to_local = graphs_.at(c->graph_to).findNode(c->node_to)->pose;
        if (forward) {
          // T_to * to_local = T_from * from_local * relative
          transform[other] = transform[g] * from_local * c->relative * to_local.inverse();
        } else {
          transform[other] = transform[g] * to_local * c->relative.inverse() * from_local.inverse();
        }
        const FloorPlacement* prev = solution_.placement(other);
        if (prev && prev->aligned && solution_.reference_graph == reference) transform[other] = prev->transform;
        frontier.push(other);
      }
    }
  }

  const std::set<int> placed = placeByFloorChanges(component_root, reference, &transform);

  pose_graph_ = graph::PoseGraph();
  std::set<int> roots_fixed;
  for (int g : order) {
    const floor::FloorGraph& fg = graphs_.at(g);
    for (const auto& node : fg.nodes) {
      const bool fix = component_root[g] == g && !roots_fixed.count(g);
      if (fix) roots_fixed.insert(g);
      pose_graph_.addNode(globalId(g, node.id), transform[g] * node.pose, fix, fg.floor_id, fg.floor_height);
    }
  }
  addEdges(pose_graph_);

  if (pose_graph_.numEdges() > 0) {
    graph::OptimizerOptions optimizer_options = options_.optimizer;
    optimizer_options.gauge = graph::GaugeMode::kPerComponent;
    graph::Optimizer optimizer(optimizer_options);
    const graph::OptimizerResult result = optimizer.optimize(pose_graph_);
    solution.initial_chi2 = result.initial_chi2;
    solution.final_chi2 = result.final_chi2;
    solution.iterations = result.iterations;
  }

  for (const auto& [g, fg] : graphs_) {
    std::vector<geometry::Pose2> local, global;
    for (const auto& node : fg.nodes) {
      const geometry::Pose2 pose = pose_graph_.node(globalId(g, node.id)).pose;
      solution.poses[{g, node.id}] = pose;
      local.push_back(node.pose);
      global.push_back(pose);
    }
    FloorPlacement placement;
    placement.graph_id = g;
    placement.floor_id = fg.floor_id;
    placement.robot = fg.robot;
    placement.height = fg.floor_height;
    placement.transform = local.empty() ? transform[g] : fitRigidTransform(local, global);
    placement.aligned = component_root[g] == component_root[reference];
    placement.placed_by_ride = !placement.aligned && placed.count(component_root[g]) > 0;
    solution.placements.push_back(placement);
  }
  solution_ = solution;
  return solution;
}

std::set<int> BuildingGraph::placeByFloorChanges(const std::map<int, int>& component_root,
                                                 int reference,
                                                 std::map<int, geometry::Pose2>* transform) const {
  // Most updates join every graph to the reference: then there is nothing to place, and
  // no need to sort every node by stamp.
  const int reference_root = component_root.at(reference);
  std::set<int> placed{reference_root};
  if (std::all_of(component_root.begin(), component_root.end(),
                  [&](const auto& entry) { return entry.second == reference_root; }))
    return placed;
  std::vector<const floor::FloorGraph*> graphs;
  for (const auto& [id, g] : graphs_) graphs.push_back(&g);
  const std::vector<floor::TransitLink> links = floor::transitLinks(graphs);
  for (bool moved = true; moved;) {
    moved = false;
    for (const floor::TransitLink& link : links) {
      const int from_root = component_root.at(link.from_graph),
                to_root = component_root.at(link.to_graph);
      const bool from_placed = placed.count(from_root) > 0, to_placed = placed.count(to_root) > 0;
      if (from_placed == to_placed) continue;
      const floor::FloorNode* from = graphs_.at(link.from_graph).findNode(link.from_node);
      const floor::FloorNode* to = graphs_.at(link.to_graph).findNode(link.to_node);
      const geometry::Pose2 ride = from->odometry.between(to->odometry);
      if (!ride.isFinite()) continue;
      // The unplaced side's set moves rigidly so that the two nodes lie as the odometry says.
      const int graph = from_placed ? link.to_graph : link.from_graph;
      const geometry::Pose2 wanted =
          from_placed
              ? transform->at(link.from_graph) * from->pose * ride * to->pose.inverse()
              : transform->at(link.to_graph) * to->pose * ride.inverse() * from->pose.inverse();
      const geometry::Pose2 shift = wanted * transform->at(graph).inverse();
      const int root = from_placed ? to_root : from_root;
      for (const auto& [g, r] : component_root)
        if (r == root) (*transform)[g] = shift * transform->at(g);
      placed.insert(root);
      moved = true;
    }
  }
  return placed;
}

void BuildingGraph::addEdges(graph::PoseGraph& pose_graph) const {
  for (const auto& [g, fg] : graphs_)
    for (const auto& edge : fg.edges)
      pose_graph.addEdge(globalId(g, edge.from), globalId(g, edge.to), edge.measurement, edge.information,
                         toGraphKind(edge.kind));
  for (const auto& c : constraints_)
    pose_graph.addEdge(globalId(c.graph_from, c.node_from), globalId(c.graph_to, c.node_to), c.relative,
                       c.information, graph::EdgeKind::kInterFloor);
}

graph::PoseGraph BuildingGraph::poseGraphAt(const BuildingSolution& solution) const {
  graph::PoseGraph pose_graph;
  for (const auto& [g, fg] : graphs_)
    for (const auto& node : fg.nodes) {
      auto pose = solution.poses.find({g, node.id});
      pose_graph.addNode(globalId(g, node.id), pose == solution.poses.end() ? node.pose : pose->second,
                         g == solution.reference_graph && &node == &fg.nodes.front(), fg.floor_id,
                         fg.floor_height);
    }
  addEdges(pose_graph);
  return pose_graph;
}

geometry::Pose2 fitRigidTransform(const std::vector<geometry::Pose2>& local,
                                  const std::vector<geometry::Pose2>& global) {
  if (local.empty() || local.size() != global.size())
    throw std::invalid_argument("fitRigidTransform needs two equally long, non-empty pose lists");
  const std::size_t n = local.size();
  Eigen::Vector2d mean_l = Eigen::Vector2d::Zero(), mean_g = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mean_l += local[i].translation();
    mean_g += global[i].translation();
  }
  mean_l /= double(n);
  mean_g /= double(n);
  // Rotation from the position cross-covariance plus the heading differences, so the fit
  // is defined for one node or collinear nodes too.
  double s = 0.0, c = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = local[i].translation() - mean_l, b = global[i].translation() - mean_g;
    c += a.dot(b);
    s += a.x() * b.y() - a.y() * b.x();
    const double dtheta = geometry::angleDiff(global[i].theta(), local[i].theta());
    c += std::cos(dtheta);
    s += std::sin(dtheta);
  }
  const double theta = std::atan2(s, c);
  const Eigen::Vector2d t = mean_g - geometry::Pose2(0, 0, theta).rotation() * mean_l;
  return geometry::Pose2(t.x(), t.y(), theta);
}

}  // namespace storey::building
