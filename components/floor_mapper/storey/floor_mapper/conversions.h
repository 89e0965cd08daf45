// storey_msgs <-> storey::mapping types, converted once at the component's boundary.
#pragma once

#include <string>

#include "storey/floor/floor_graph.h"
#include "storey/mapping/floor_slam.h"
#include "storey_msgs/msg/FloorGraphUpdate.h"

namespace storey::floor_mapper {

// One update of a floor graph: its new nodes (with scans) and edges, and the poses of
// every node when the graph was re-optimised (else of the new nodes). A scan's sensor
// offset is not on the wire: scans are sent as they are (robot-frame convention).
storey_msgs::msg::FloorGraphUpdate toMessage(const floor::FloorGraph& graph,
                                             const mapping::GraphUpdate& update,
                                             std::uint32_t sequence_number);

}  // namespace storey::floor_mapper
