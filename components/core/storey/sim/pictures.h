// Pictures of the true building: one map per floor and overlays of floors (as in Fig. 4 of
// Karg et al. 2010), drawn from the exact geometry in the building frame.
#pragma once

#include <string>
#include <vector>

#include "storey/grid/image.h"
#include "storey/sim/building.h"

namespace storey::sim {

struct PictureOptions {
  double resolution = 0.05;  // metres per pixel (coarser for a building that would need over 2.5e7)
  double margin = 1.0;       // metres around the building
};

// Black walls on white for one floor (index into Building::floors), building frame, north up.
grid::Image renderFloor(const Building& building, int floor, const PictureOptions& options = {});
// The given floors in one RGB picture, one colour per floor.
grid::Image renderOverlay(const Building& building, const std::vector<int>& floors,
                          const PictureOptions& options = {});
// Writes floor_<id>.png for every floor, overlay_<a>_<b>.png for consecutive floors and
// overlay_all.png into `dir`. Returns the files written.
std::vector<std::string> writePictures(const Building& building, const std::string& dir,
                                       const PictureOptions& options = {});

}  // namespace storey::sim
