// The building as a building: the floors stacked at their heights and seen from above at
// an angle (an isometric view, as in Karg et al.'s Fig. 1), for the report.
#pragma once

#include <map>

#include "storey/building/building_graph.h"
#include "storey/building/building_outputs.h"
#include "storey/grid/image.h"

namespace storey::building {

// Each floor's occupied cells in its floor colour, the lowest floor drawn first, with a
// grey outline 1 m around them at its height; with `graph` and `solution`, a black
// line for each inter-floor constraint between its two nodes. `width` pixels wide. Heights
// are stretched so that one storey spans about half a floor's drawn depth (floors a few
// metres apart under a plan tens of metres wide would hide each other), the whole picture
// at most twice as high as wide.
grid::Image renderIsometric(const std::map<int, FloorMap>& floors, int width = 900,
                            const BuildingGraph* graph = nullptr,
                            const BuildingSolution* solution = nullptr);

}  // namespace storey::building
