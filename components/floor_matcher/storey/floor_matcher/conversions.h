// floor_matcher's message conversions, in one place: storey_msgs <-> core.
#pragma once

#include <map>

#include "storey/floor/floor_graph.h"
#include "storey/matching/floor_matcher.h"
#include "storey_msgs/msg/FloorGraphUpdate.h"
#include "storey_msgs/msg/InterFloorConstraint.h"

namespace storey::floor_matcher {

// Applies one update to `graphs` (keyed by floor graph id): new nodes (a node already
// present is not duplicated), new edges, then the optimised poses. The message carries no
// raw odometry, so a node's odometry is its pose when it arrived. Throws
// std::invalid_argument naming the graph, update and field for non-finite values, bad scans
// or poses of unknown nodes; `graphs` is unchanged then.
void applyUpdate(const storey_msgs::msg::FloorGraphUpdate& message,
                 std::map<int, floor::FloorGraph>* graphs);

// An accepted constraint with its evidence (l_t, l_min, scans used, RANSAC support).
storey_msgs::msg::InterFloorConstraint toMessage(const matching::InterFloorConstraint& constraint,
                                                 std::uint32_t id, double l_min,
                                                 std::uint32_t support);

// The constraint a message names (nodes and measurement; evidence is not read back).
matching::InterFloorConstraint constraintFromMessage(const storey_msgs::msg::InterFloorConstraint& message);

}  // namespace storey::floor_matcher
