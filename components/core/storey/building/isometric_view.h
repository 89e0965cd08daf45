// The building as a building: the floors stacked at their heights and seen from above at
// an angle (an isometric view, as in Karg et al.'s Fig. 1), for the report.
#pragma once

#include <map>

#include "storey/building/building_graph.h"
#include "storey/building/building_outputs.h"
#include "storey/grid/image.h"

namespace storey::building {

// Each floor's occupied cells in its floor colour, the lowest floor drawn first, with a
// grey outline 1 m around them at its height. With `graph` and `solution`: each floor
// graph's path (its nodes in order) on its floor in its robot's colour (robotColour, robots
// by name), each ride as a line in that colour from a robot's last node before a floor
// change to its first after (node stamps), and, when `constraints`, a black line for each
// inter-floor constraint between its two nodes. `width` pixels wide. Heights are stretched
// so that one storey spans about half a floor's drawn depth (floors a few metres apart under
// a plan tens of metres wide would hide each other), the whole picture at most twice as
// high as wide.
grid::Image renderIsometric(const std::map<int, FloorMap>& floors, int width = 900,
                            const BuildingGraph* graph = nullptr,
                            const BuildingSolution* solution = nullptr, bool constraints = true);

}  // namespace storey::building
