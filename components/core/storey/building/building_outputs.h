// What storey writes for a building: per-floor maps in the building frame (nav2
// map_server PGM+YAML and PNG), building.yaml (floors, heights, transforms) and the building OctoMap (.bt).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

#include "storey/building/building_graph.h"
#include "storey/common/config.h"
#include "storey/grid/image.h"
#include "storey/grid/occupancy_grid.h"

namespace storey::building {

struct FloorMap {
  int floor_id = 0;
  double height = 0.0;
  grid::OccupancyGrid grid;
};

// Every floor's scans at their optimised building-frame poses, one grid per floor id
// (graphs of the same floor, e.g. from several robots, share one map).
std::map<int, FloorMap> renderBuildingFloors(const BuildingGraph& graph, const BuildingSolution& solution,
                                             const grid::OccupancyGridOptions& options);

struct OctomapOptions {
  double resolution = 0.1;      // voxel edge (metres)
  double wall_height = 2.5;     // occupied cells are extruded this far above the floor
  double sensor_height = 0.3;   // free space is marked at this height above the floor
};

// Writes a binary OcTree: each floor's occupied cells extruded between the floor height and
// floor height + wall_height, and its free cells as free voxels at the sensor height.
// Returns the number of occupied leaf voxels. Throws std::runtime_error naming the file.
std::size_t writeBuildingOctomap(const std::string& path, const std::map<int, FloorMap>& floors,
                                 const OctomapOptions& options);

void writeBuildingYaml(const std::string& path, const BuildingSolution& solution,
                       const std::map<int, FloorMap>& floors);

// The colour pictures use for the index-th floor (a fixed palette, repeating).
std::array<std::uint8_t, 3> floorColour(std::size_t index);
// Colours for robots' paths: none a floor colour, the outline's grey or black.
std::array<std::uint8_t, 3> robotColour(std::size_t index);

// Overlay of floors in one picture (the paper's Fig. 4): each floor's occupied cells in its
// own colour over a common frame.
grid::Image renderFloorOverlay(const std::map<int, FloorMap>& floors);

}  // namespace storey::building
