#include "storey/floor/floor_graph.h"

#include <limits>

namespace storey::floor {

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

int FloorGraph::nearestNodeIndex(const Eigen::Vector2d& point) const {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < nodes.size(); ++i) {
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

}  // namespace storey::floor
