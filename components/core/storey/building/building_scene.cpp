#include "storey/building/building_scene.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <utility>

namespace storey::building {

namespace {

SceneFloor sceneFloor(const FloorMap& floor, Colour colour) {
  SceneFloor out;
  out.floor_id = floor.floor_id;
  out.height = floor.height;
  out.colour = colour;
  const grid::GridFrame& f = floor.grid.frame();
  for (int cy = 0; cy < f.height; ++cy)
    for (int cx = 0; cx < f.width; ++cx)
      if (floor.grid.stateAt(cx, cy) == grid::CellState::kOccupied)
        out.walls.push_back(f.centerOf(cx, cy));
  if (out.walls.empty()) return out;
  out.x0 = out.x1 = out.walls.front().x();
  out.y0 = out.y1 = out.walls.front().y();
  for (const Eigen::Vector2d& w : out.walls) {
    out.x0 = std::min(out.x0, w.x());
    out.y0 = std::min(out.y0, w.y());
    out.x1 = std::max(out.x1, w.x());
    out.y1 = std::max(out.y1, w.y());
  }
  out.x0 -= 1.0;
  out.y0 -= 1.0;
  out.x1 += 1.0;
  out.y1 += 1.0;
  return out;
}

}  // namespace

BuildingScene buildingScene(const std::map<int, FloorMap>& floors, const BuildingGraph* graph,
                            const BuildingSolution* solution, bool constraints) {
  BuildingScene scene;
  std::size_t rank = 0;
  for (const auto& [id, floor] : floors) {
    SceneFloor f = sceneFloor(floor, floorColour(rank++));
    if (!f.walls.empty()) scene.floors.push_back(std::move(f));
  }
  std::stable_sort(scene.floors.begin(), scene.floors.end(),
                   [](const SceneFloor& a, const SceneFloor& b) { return a.height < b.height; });
  if (!graph || !solution) return scene;

  std::map<std::string, Colour> robot_colour;
  for (const auto& [id, g] : graph->floorGraphs()) robot_colour.emplace(g.robot, Colour{});
  std::size_t next_robot = 0;
  for (auto& entry : robot_colour) entry.second = robotColour(next_robot++);
  // A node's place in the building: position and its floor graph's height.
  auto nodeAt = [&](int graph_id, int node_id, Eigen::Vector3d* at) {
    const auto pose = solution->poses.find({graph_id, node_id});
    const FloorPlacement* placement = solution->placement(graph_id);
    if (pose == solution->poses.end() || !placement) return false;
    *at = {pose->second.x(), pose->second.y(), placement->height};
    return true;
  };

  for (const auto& [id, g] : graph->floorGraphs()) {
    const FloorPlacement* placement = solution->placement(id);
    if (!placement) continue;
    SceneLine path{placement->floor_id, robot_colour.at(g.robot), {}};
    Eigen::Vector3d at;
    for (const floor::FloorNode& n : g.nodes)
      if (nodeAt(id, n.id, &at)) path.points.push_back(at);
    if (path.points.size() > 1) scene.paths.push_back(std::move(path));
  }

  // Rides: where a robot's nodes, in stamp order, pass from one floor graph to another.
  struct Visit {
    double stamp;
    int graph_id, node_id;
  };
  std::map<std::string, std::vector<Visit>> visits;
  for (const auto& [id, g] : graph->floorGraphs())
    for (const floor::FloorNode& n : g.nodes) visits[g.robot].push_back({n.stamp, id, n.id});
  for (auto& [robot, v] : visits) {
    std::stable_sort(v.begin(), v.end(),
                     [](const Visit& a, const Visit& b) { return a.stamp < b.stamp; });
    for (std::size_t k = 1; k < v.size(); ++k) {
      if (v[k].graph_id == v[k - 1].graph_id) continue;
      SceneLine ride{-1, robot_colour.at(robot), {Eigen::Vector3d(), Eigen::Vector3d()}};
      if (nodeAt(v[k - 1].graph_id, v[k - 1].node_id, &ride.points[0]) &&
          nodeAt(v[k].graph_id, v[k].node_id, &ride.points[1]))
        scene.rides.push_back(std::move(ride));
    }
  }

  if (constraints)
    for (const auto& c : graph->constraints()) {
      SceneLine line{-1, Colour{0, 0, 0}, {Eigen::Vector3d(), Eigen::Vector3d()}};
      if (nodeAt(c.graph_from, c.node_from, &line.points[0]) &&
          nodeAt(c.graph_to, c.node_to, &line.points[1]))
        scene.constraints.push_back(std::move(line));
    }
  return scene;
}

double thinWalls(BuildingScene& scene, double cell, std::size_t max_points) {
  cell = std::max(cell, 1e-3);
  // The points each floor keeps with squares of `size`.
  auto thinned = [&](double size) {
    std::vector<std::vector<Eigen::Vector2d>> kept(scene.floors.size());
    for (std::size_t i = 0; i < scene.floors.size(); ++i) {
      std::set<std::pair<long long, long long>> seen;
      for (const Eigen::Vector2d& w : scene.floors[i].walls)
        if (seen.emplace(std::llround(std::floor(w.x() / size)),
                         std::llround(std::floor(w.y() / size)))
                .second)
          kept[i].push_back(w);
    }
    return kept;
  };
  for (;; cell *= 2) {
    auto kept = thinned(cell);
    std::size_t total = 0;
    for (const auto& k : kept) total += k.size();
    // Squares wider than any building leave a few points per floor.
    if (total <= max_points || cell > 1e4) {
      for (std::size_t i = 0; i < scene.floors.size(); ++i)
        scene.floors[i].walls = std::move(kept[i]);
      return cell;
    }
  }
}

}  // namespace storey::building
