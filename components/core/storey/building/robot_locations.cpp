#include "storey/building/robot_locations.h"

#include <map>

namespace storey::building {

std::vector<RobotLocation> robotLocations(const BuildingGraph& building,
                                          const BuildingSolution& solution) {
  std::map<std::string, RobotLocation> newest;
  for (const auto& [graph_id, graph] : building.floorGraphs()) {
    if (graph.nodes.empty()) continue;
    // Nodes are kept in time order: the last is the graph's newest.
    const floor::FloorNode& node = graph.nodes.back();
    const auto pose = solution.poses.find({graph_id, node.id});
    if (pose == solution.poses.end()) continue;
    auto it = newest.find(graph.robot);
    if (it != newest.end() && it->second.stamp >= node.stamp) continue;
    RobotLocation location;
    location.robot = graph.robot;
    location.stamp = node.stamp;
    location.graph_id = graph_id;
    location.floor_id = graph.floor_id;
    location.floor_height = graph.floor_height;
    const FloorPlacement* placement = solution.placement(graph_id);
    location.aligned = placement && placement->aligned;
    location.pose = pose->second;
    location.odometry = node.odometry;
    newest[graph.robot] = location;
  }
  std::vector<RobotLocation> out;
  for (auto& [robot, location] : newest) out.push_back(location);
  return out;
}

}  // namespace storey::building
