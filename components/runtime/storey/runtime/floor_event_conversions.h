// storey_msgs/FloorEvent <-> floor::FloorEvent, converted once at the boundary: the
// floor_detector sends them, the floor_mapper reads them.
#pragma once

#include <string>

#include "storey/floor/floor_event.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorIdentity.h"

namespace storey::runtime {

// TransitStarted carries floor_id FLOOR_UNKNOWN (-1) and the height of the floor left;
// TransitEnded the floor reached (the floor it left when the ride did not change floor);
// Progress only decided_at; AwaitingIdentity the stamp of the TransitEnded it waits for.
storey_msgs::msg::FloorEvent toMessage(const floor::FloorEvent& event, const std::string& robot);
// The fields the message has; from_floor, start_stamp and floor_changed are not on the
// wire (floor_changed is left true for TransitEnded). A zero decided_at (a publisher that
// does not set it) becomes the event's stamp. Throws std::invalid_argument for an unknown
// kind, a non-finite stamp or a TransitEnded with a non-finite floor height.
floor::FloorEvent fromMessage(const storey_msgs::msg::FloorEvent& message);

storey_msgs::msg::FloorIdentity toMessage(const floor::FloorIdentity& identity,
                                          const std::string& robot);
// Throws std::invalid_argument for a non-finite stamp or a negative floor id.
floor::FloorIdentity fromMessage(const storey_msgs::msg::FloorIdentity& message);

}  // namespace storey::runtime
