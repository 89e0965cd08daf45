// Floor graphs from recorded laser logs (CARMEN corrected logs: the pose of each line is the
// SLAM-corrected pose, used as the floor graph's node pose). The odometry between nodes is
// derived from the corrected poses with fresh, seeded noise, so replaying it in the matcher
// is as hard as with a real robot's odometry. A graph can be placed in a frame of its own
// (a known SE(2) offset) to test that the matcher recovers it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "storey/floor/floor_graph.h"
#include "storey/geometry/pose2.h"
#include "storey/io/carmen.h"

namespace storey::eval {

struct LogFloorOptions {
  double node_distance = 0.3;  // metres between nodes
  double node_angle = 0.3;     // radians between nodes
  // Odometry noise per step, as standard deviations: translation sigma per metre driven,
  // heading sigma per radian turned and per metre driven.
  double odometry_translation_sigma = 0.05;
  double odometry_rotation_sigma = 0.05;
  double odometry_rotation_per_metre = 0.01;
  std::size_t first = 0;  // laser records [first, last) of the log are used
  std::size_t last = std::numeric_limits<std::size_t>::max();
  geometry::Pose2 frame;  // the graph's frame in the log's frame: node pose = frame^-1 * log pose
  int graph_id = 0;
  int floor_id = 0;
  double floor_height = 0.0;
  std::uint64_t seed = 1;
};

floor::FloorGraph floorGraphFromLasers(const std::vector<io::CarmenLaser>& lasers,
                                       const LogFloorOptions& options);

}  // namespace storey::eval
