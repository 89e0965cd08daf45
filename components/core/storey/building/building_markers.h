// The building graph drawn for a viewer (RViz, Foxglove: the graph server sends it as a
// visualization_msgs/MarkerArray): per floor graph a line through its nodes at its floor's
// height, the inter-floor constraints as lines between the nodes they tie, and a label
// per floor. Colours tell the floors apart; a floor graph not yet joined to the
// reference by constraints is grey.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "storey/building/building_graph.h"

namespace storey::building {

struct BuildingMarker {
  enum class Kind { kLineStrip, kLineList, kText };
  Kind kind = Kind::kLineStrip;
  std::string ns;  // "floor_graphs" (id: graph id), "constraints" (id 0), "floors" (id: floor id)
  int id = 0;
  std::array<float, 4> rgba{1.0f, 1.0f, 1.0f, 1.0f};
  std::vector<Eigen::Vector3d> points;  // building frame, m; a label: its position
  std::string text;                     // a label's text
};

// In a fixed order (floor graphs by id, then the constraints, then labels by floor id).
std::vector<BuildingMarker> buildingMarkers(const BuildingGraph& building,
                                            const BuildingSolution& solution);

}  // namespace storey::building
