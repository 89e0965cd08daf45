// storey render LOG OUT.png: draws the occupancy map of a CARMEN/GMapping log from the
// poses in it.
#include <iostream>

#include "args.h"
#include "storey/common/log.h"
#include "storey/grid/image.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/io/log_map.h"

namespace storey::cli {

extern const char* const summary_render =
    "draw the map of a CARMEN/GMapping log from its poses (PNG, nav2)";

int run_render(Args& args) {
  args.usage("LOG OUT.png",
             "Reads a CARMEN log (FLASER, RLASER, ROBOTLASER, plain or .gz) or a GMapping .gfs\n"
             "log and draws the occupancy grid of its scans at the poses in the log. Corrected\n"
             "logs carry the SLAM-corrected pose, so --pose corrected draws the corrected map.\n"
             "Writes a grey PNG (black occupied, white free, grey unknown; top row = largest y).")
      .option("resolution", "R", "metres per cell", "0.05")
      .option("pose", "corrected|odometry",
              "the laser pose of each line, or its odometry pose (.gfs lines have only odometry)",
              "corrected")
      .option("laser", "ID", "laser to draw: 1 front, 2 rear, ..., 0 every laser", "1")
      .option("first-scan", "N", "scans skipped before drawing", "0")
      .option("max-scans", "N", "scans drawn at most (0: all)", "0")
      .option("max-range", "M", "returns beyond M metres are not drawn (0: the laser's limit)", "0")
      .option("map-server", "STEM", "also write STEM.pgm and STEM.yaml (nav2 map_server)")
      .flag("lenient", "skip malformed lines (counted) instead of stopping at the first");
  if (!args.parse()) return 0;
  const std::string log_path = args.positional(0, "LOG");
  const std::string png_path = args.positional(1, "OUT.png");
  if (args.positionals().size() > 2) throw UsageError("too many arguments (see --help)");

  io::LogMapOptions options;
  options.grid.resolution = args.getDouble("resolution");
  if (!(options.grid.resolution > 0.0) || options.grid.resolution > 10.0)
    throw UsageError("--resolution must be in (0, 10] metres");
  const std::string pose = args.get("pose");
  if (pose == "corrected")
    options.pose = io::LogPose::kCorrected;
  else if (pose == "odometry")
    options.pose = io::LogPose::kOdometry;
  else
    throw UsageError("--pose must be corrected or odometry, got '" + pose + "'");
  const long laser = args.getInt("laser"), first = args.getInt("first-scan"),
             max = args.getInt("max-scans");
  if (laser < 0 || laser > 4) throw UsageError("--laser must be 0..4");
  if (first < 0 || max < 0) throw UsageError("--first-scan and --max-scans must not be negative");
  options.laser_id = static_cast<int>(laser);
  options.first_scan = static_cast<std::size_t>(first);
  options.max_scans = static_cast<std::size_t>(max);
  options.grid.max_insert_range = args.getDouble("max-range");
  if (options.grid.max_insert_range < 0.0) throw UsageError("--max-range must not be negative");
  options.reader.strict = !args.flagSet("lenient");

  const io::LogMap map = io::mapFromLog(log_path, options);
  const io::CarmenStats& stats = map.stats;
  common::logInfo(common::str(log_path, ": ", stats.summary()));
  for (const std::string& problem : stats.problems) common::logDebug(problem);
  if (options.pose == io::LogPose::kCorrected && stats.recordCount("LASER_READING") > 0)
    common::logWarn(
        "LASER_READING lines carry only the raw odometry pose: the map is drawn from odometry");
  if (map.scans_inserted == 0 || map.grid.empty())
    throw std::runtime_error(log_path + ": no scan with a pose and a return to draw");
  grid::writePng(png_path, grid::renderGrey(map.grid));
  const grid::GridFrame& f = map.grid.frame();
  std::cout << "drew " << map.scans_inserted << " scans into " << f.width << "x" << f.height
            << " cells at " << f.resolution << " m, origin (" << f.origin_x << ", " << f.origin_y
            << "): " << png_path << "\n";
  if (args.has("map-server")) {
    const std::string stem = args.get("map-server");
    grid::writeMapServerFiles(map.grid, stem);
    std::cout << "wrote " << stem << ".pgm and " << stem << ".yaml\n";
  }
  return 0;
}

}  // namespace storey::cli
