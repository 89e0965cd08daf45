#include "storey/floor/floor_graph.h"

#include <algorithm>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

namespace storey::floor {

void requireSameRobot(const FloorGraph& graph, const std::string& robot) {
  if (graph.robot == robot) return;
  throw std::invalid_argument("floor graph " + std::to_string(graph.graph_id) + " belongs to robot '" + graph.robot +
                              "', not '" + robot + "' (floor-graph ids must be unique across robots)");
}

const char* edgeKindName(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry: return "odometry";
    case EdgeKind::kScanMatch: return "scan_match";
    case EdgeKind::kLoopClosure: return "loop_closure";
  }
  return "unknown";
}

const FloorNode* FloorGraph::findNode(int id) const {
  for (const auto& node : nodes)
    if (node.id == id) return &node;
  return nullptr;
}

int FloorGraph::nearestNodeIndex(const Eigen::Vector2d& point, std::size_t count) const {
  return nearestNodeIndex(point, 0, count);
}

int FloorGraph::nearestNodeIndex(const Eigen::Vector2d& point, std::size_t first, std::size_t end) const {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = first; i < std::min(end, nodes.size()); ++i) {
    const double d2 = (nodes[i].pose.translation() - point).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = static_cast<int>(i);
    }
  }
  return best;
}

grid::OccupancyGrid renderFloorMap(const FloorGraph& graph, const grid::OccupancyGridOptions& options) {
  grid::OccupancyGrid map(options);
  for (const auto& node : graph.nodes) map.insertScan(node.scan, node.pose);
  return map;
}

std::vector<Eigen::Vector2d> floorPoints(const FloorGraph& graph, const std::vector<std::size_t>& indices,
                                         double max_range) {
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i : indices) {
    const FloorNode& node = graph.nodes.at(i);
    const double range_max = static_cast<double>(node.scan.range_max);
    const double limit = max_range > 0.0 ? std::min(max_range, range_max) : range_max;
    const Eigen::Vector2d sensor = node.scan.sensor_offset.translation();
    std::vector<Eigen::Vector2d> near;
    for (const auto& p : node.scan.pointsInRobotFrame())
      if ((p - sensor).norm() < limit) near.push_back(p);
    node.pose.transformPoints(near, &near);
    points.insert(points.end(), near.begin(), near.end());
  }
  return points;
}

std::vector<Eigen::Vector2d> floorPoints(const FloorGraph& graph, std::size_t first, std::size_t last,
                                         double max_range) {
  std::vector<std::size_t> indices;
  for (std::size_t i = first; i < last && i < graph.nodes.size(); ++i) indices.push_back(i);
  return floorPoints(graph, indices, max_range);
}

std::vector<TransitLink> transitLinks(const std::vector<FloorGraph>& graphs) {
  std::vector<const FloorGraph*> pointers;
  for (const auto& g : graphs) pointers.push_back(&g);
  return transitLinks(pointers);
}

std::vector<TransitLink> transitLinks(const std::vector<const FloorGraph*>& graphs) {
  std::map<std::string, std::vector<std::tuple<double, int, int>>>
      by_robot;  // (stamp, graph, node)
  for (const FloorGraph* g : graphs)
    for (const auto& n : g->nodes) by_robot[g->robot].emplace_back(n.stamp, g->graph_id, n.id);
  std::vector<TransitLink> links;
  for (auto& [robot, nodes] : by_robot) {
    std::sort(nodes.begin(), nodes.end());
    for (std::size_t i = 1; i < nodes.size(); ++i) {
      const auto& [t0, g0, n0] = nodes[i - 1];
      const auto& [t1, g1, n1] = nodes[i];
      if (g0 != g1) links.push_back({g0, n0, g1, n1});
    }
  }
  return links;
}

}  // namespace storey::floor
