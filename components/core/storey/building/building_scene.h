// The building as drawing primitives in the building frame, shared by the isometric
// pictures and the report's interactive view: each floor's walls (occupied cells), each
// floor graph's path, the robots' rides between floors and the inter-floor constraints.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/building/building_outputs.h"

namespace storey::building {

using Colour = std::array<std::uint8_t, 3>;

struct SceneFloor {
  int floor_id = 0;
  double height = 0.0;
  Colour colour{};                     // floorColour of its rank by floor id
  std::vector<Eigen::Vector2d> walls;  // occupied cell centres (metres)
  // The walls' extent, 1 m around them (a grid holds room to grow); empty when no walls.
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// A polyline in the building frame (x, y, height).
struct SceneLine {
  int floor_id = -1;  // the floor a path lies on; -1 for rides and constraints
  Colour colour{};
  std::vector<Eigen::Vector3d> points;
};

struct BuildingScene {
  std::vector<SceneFloor> floors;  // floors with walls, lowest first
  std::vector<SceneLine> paths;    // one per floor graph: its nodes in order, robot's colour
  // A robot's last node before a floor change to its first after (node stamps), robot's colour.
  std::vector<SceneLine> rides;
  std::vector<SceneLine> constraints;  // between the two nodes of each, black
};

// The scene of `floors`; with `graph` and `solution` also the paths, rides and (when
// `constraints`) the inter-floor constraints. Robots are coloured robotColour by the rank
// of their name.
BuildingScene buildingScene(const std::map<int, FloorMap>& floors,
                            const BuildingGraph* graph = nullptr,
                            const BuildingSolution* solution = nullptr, bool constraints = true);

// Keeps one wall point per square of `cell` metres on each floor, the square doubled until
// the scene holds at most `max_points` wall points. Returns the square used.
double thinWalls(BuildingScene& scene, double cell, std::size_t max_points);

}  // namespace storey::building
