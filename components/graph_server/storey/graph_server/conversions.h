// graph_server's message conversions, in one place: storey_msgs / nav_msgs <-> core.
#pragma once

#include "nav_msgs/msg/OccupancyGrid.h"
#include "storey/building/building_markers.h"
#include "storey/building/building_outputs.h"
#include "storey/building/journal.h"
#include "storey_msgs/msg/BuildingState.h"
#include "storey_msgs/msg/FloorGraphUpdate.h"
#include "storey_msgs/msg/InterFloorConstraint.h"
#include "visualization_msgs/msg/MarkerArray.h"

namespace storey::graph_server {

// Throws std::invalid_argument naming the field for values that cannot be accepted
// (non-finite poses, scans with bad limits, unknown edge kinds).
building::FloorGraphDelta fromMessage(const storey_msgs::msg::FloorGraphUpdate& message);
building::InterGraphConstraint fromMessage(const storey_msgs::msg::InterFloorConstraint& message);
// The retraction a message with `retracted` set carries.
building::ConstraintRetraction retractionFromMessage(const storey_msgs::msg::InterFloorConstraint& message);

// The optimised building, with the constraints it held (`constraints`).
storey_msgs::msg::BuildingState toMessage(const building::BuildingSolution& solution,
                                          const std::vector<building::InterGraphConstraint>& constraints,
                                          std::uint32_t sequence, double stamp);
nav_msgs::msg::OccupancyGrid toMessage(const building::FloorMap& floor, double stamp);
// In the "building" frame; a DELETEALL first, so each array replaces the last one whole.
visualization_msgs::msg::MarkerArray toMessage(const std::vector<building::BuildingMarker>& markers,
                                               double stamp);

}  // namespace storey::graph_server
