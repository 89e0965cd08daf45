#include "storey/building/building_markers.h"

#include <map>

namespace storey::building {

namespace {

// Distinct hues, one per floor id (cycled).
std::array<float, 4> floorColour(int floor_id) {
  static const std::array<std::array<float, 4>, 6> kPalette{{{0.12f, 0.47f, 0.71f, 1.0f},
                                                             {0.17f, 0.63f, 0.17f, 1.0f},
                                                             {0.84f, 0.15f, 0.16f, 1.0f},
                                                             {0.58f, 0.40f, 0.74f, 1.0f},
                                                             {0.09f, 0.75f, 0.81f, 1.0f},
                                                             {0.55f, 0.34f, 0.29f, 1.0f}}};
  const std::size_t n = kPalette.size();
  return kPalette[(static_cast<std::size_t>(floor_id % static_cast<int>(n)) + n) % n];
}

}  // namespace

std::vector<BuildingMarker> buildingMarkers(const BuildingGraph& building,
                                            const BuildingSolution& solution) {
  std::vector<BuildingMarker> out;
  // Each node's position in the building, and each floor's height and first node.
  auto height = [&](int graph_id, double fallback) {
    const FloorPlacement* placement = solution.placement(graph_id);
    return placement ? placement->height : fallback;
  };
  std::map<int, Eigen::Vector3d> label_at;
  for (const auto& [graph_id, graph] : building.floorGraphs()) {
    BuildingMarker strip;
    strip.kind = BuildingMarker::Kind::kLineStrip;
    strip.ns = "floor_graphs";
    strip.id = graph_id;
    const FloorPlacement* placement = solution.placement(graph_id);
    strip.rgba = placement && placement->aligned ? floorColour(graph.floor_id)
                                                 : std::array<float, 4>{0.6f, 0.6f, 0.6f, 1.0f};
    const double z = height(graph_id, graph.floor_height);
    for (const auto& node : graph.nodes) {
      const auto pose = solution.poses.find({graph_id, node.id});
      if (pose == solution.poses.end()) continue;
      strip.points.emplace_back(pose->second.x(), pose->second.y(), z);
    }
    if (strip.points.empty()) continue;
    label_at.emplace(graph.floor_id, strip.points.front());
    out.push_back(std::move(strip));
  }
  BuildingMarker lines;
  lines.kind = BuildingMarker::Kind::kLineList;
  lines.ns = "constraints";
  lines.rgba = {1.0f, 0.6f, 0.0f, 1.0f};
  for (const auto& c : building.constraints()) {
    const auto from = solution.poses.find({c.graph_from, c.node_from});
    const auto to = solution.poses.find({c.graph_to, c.node_to});
    const auto from_graph = building.floorGraphs().find(c.graph_from);
    const auto to_graph = building.floorGraphs().find(c.graph_to);
    if (from == solution.poses.end() || to == solution.poses.end() ||
        from_graph == building.floorGraphs().end() || to_graph == building.floorGraphs().end())
      continue;
    lines.points.emplace_back(from->second.x(), from->second.y(),
                              height(c.graph_from, from_graph->second.floor_height));
    lines.points.emplace_back(to->second.x(), to->second.y(),
                              height(c.graph_to, to_graph->second.floor_height));
  }
  if (!lines.points.empty()) out.push_back(std::move(lines));
  for (const auto& [floor_id, at] : label_at) {
    BuildingMarker label;
    label.kind = BuildingMarker::Kind::kText;
    label.ns = "floors";
    label.id = floor_id;
    label.rgba = floorColour(floor_id);
    label.points = {at};
    label.text = "floor " + std::to_string(floor_id);
    out.push_back(std::move(label));
  }
  return out;
}

}  // namespace storey::building
