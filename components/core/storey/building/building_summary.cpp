#include "storey/building/building_summary.h"

#include <set>

namespace storey::building {

BuildingSummary summarizeBuilding(const BuildingGraph& graph, const BuildingSolution& solution) {
  BuildingSummary s;
  std::set<int> floors, to_check;
  std::set<std::string> robots;
  for (const FloorPlacement& p : solution.placements) {
    floors.insert(p.floor_id);
    robots.insert(p.robot);
    ++s.graphs;
    if (p.aligned) {
      ++s.aligned_graphs;
      continue;
    }
    to_check.insert(p.floor_id);
    const auto it = graph.floorGraphs().find(p.graph_id);
    const std::size_t nodes = it == graph.floorGraphs().end() ? 0 : it->second.nodes.size();
    s.warnings.push_back("floor " + std::to_string(p.floor_id) + " (graph " +
                         std::to_string(p.graph_id) + ", robot " + p.robot + ", " +
                         std::to_string(nodes) + " nodes): no inter-floor constraint; " +
                         (p.placed_by_ride ? "placed by the robot's odometry through its ride"
                                           : "left in its own frame (no ride links it)"));
  }
  s.floors = static_cast<int>(floors.size());
  s.robots = static_cast<int>(robots.size());
  s.constraints = static_cast<int>(graph.constraints().size());
  s.floors_to_check.assign(to_check.begin(), to_check.end());
  return s;
}

}  // namespace storey::building
