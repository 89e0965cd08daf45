// An occupancy grid drawn from the scans of a CARMEN/GMapping log at the poses the log
// gives (corrected logs carry the SLAM-corrected pose; every log carries odometry).
#pragma once

#include <cstddef>
#include <string>

#include "storey/grid/occupancy_grid.h"
#include "storey/io/carmen.h"

namespace storey::io {

enum class LogPose {
  kCorrected,  // the laser pose of each line (FLASER x y θ, ROBOTLASER laser pose)
  kOdometry,   // the odometry pose of each line, with the laser's offset on the robot
};

struct LogMapOptions {
  grid::OccupancyGridOptions grid;
  CarmenReaderOptions reader;
  LogPose pose = LogPose::kCorrected;
  int laser_id = 1;            // which laser (1 front, 2 rear...); 0: every laser
  std::size_t first_scan = 0;  // scans of that laser skipped before drawing
  std::size_t max_scans = 0;   // 0: all
};

struct LogMap {
  grid::OccupancyGrid grid;
  std::size_t scans_inserted = 0;
  CarmenStats stats;
};

// Streams the log (never all of it in memory). Throws CarmenError as the reader does.
LogMap mapFromLog(const std::string& path, const LogMapOptions& options);

}  // namespace storey::io
