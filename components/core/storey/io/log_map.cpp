#include "storey/io/log_map.h"

namespace storey::io {

LogMap mapFromLog(const std::string& path, const LogMapOptions& options) {
  LogMap result{grid::OccupancyGrid(options.grid), 0, {}};
  CarmenReader reader(path, options.reader);
  CarmenRecord record;
  std::size_t seen = 0;
  while (reader.next(&record)) {
    if (record.kind != CarmenRecordKind::kLaser || !record.laser.has_pose) continue;
    if (options.laser_id != 0 && record.laser.laser_id != options.laser_id) continue;
    if (seen++ < options.first_scan) continue;
    if (options.max_scans > 0 && result.scans_inserted >= options.max_scans) break;
    const CarmenLaser& laser = record.laser;
    // insertScan places the sensor at robot_pose * sensor_offset: for the corrected pose,
    // hand it the robot pose that puts the laser exactly where the log says.
    const geometry::Pose2 robot =
        options.pose == LogPose::kCorrected ? laser.robotPose() : laser.odom_pose;
    result.grid.insertScan(laser.scan, robot);
    ++result.scans_inserted;
  }
  result.stats = reader.stats();
  return result;
}

}  // namespace storey::io
