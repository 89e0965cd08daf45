// The report's interactive 3D view: the building scene (walls, paths, rides, inter-floor
// constraints) embedded in the HTML as JSON and drawn on a canvas by a short script, so the
// view works from the file alone with no network.
#pragma once

#include <ostream>

#include "storey/building/building_scene.h"

namespace storey::tools {

// Wall points the view holds at most: about 1 MB of the report (coordinates in centimetres),
// and few enough to redraw on every mouse move.
inline constexpr std::size_t kViewWallPoints = 60000;

// Writes "<h2>3D view</h2>", the canvas, its controls (a box per floor, paths and rides,
// constraints, a height stretch, reset) and the script. Thins `scene`'s walls to
// kViewWallPoints, starting from 0.1 m squares (a wall's thickness).
void writeInteractiveView(std::ostream& out, building::BuildingScene scene);

}  // namespace storey::tools
