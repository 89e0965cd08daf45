// The report's timeline: per robot, its height over time (the floors it mapped, from its
// floor graphs' node stamps) and every ride the floor detector reported, as an inline SVG
// and a table.
#pragma once

#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/floor/floor_event.h"

namespace storey::tools {

// TransitEnded events per robot, in the order they were published, with the start stamp
// and height of their TransitStarted.
using RobotRides = std::map<std::string, std::vector<floor::FloorEvent>>;

// Writes "<h2>Timeline</h2>" and, per robot with floor graphs, an SVG (time on x, height
// on y: a line per stretch on a floor, each ride from its start to its end coloured by its
// mode) and a table of its rides (start, end, the floor mapped before it and the floor
// reached, mode, confidence). `rides` null: not known, only the floors over time.
void writeTimeline(std::ostream& out, const building::BuildingGraph& graph,
                   const RobotRides* rides);

}  // namespace storey::tools
