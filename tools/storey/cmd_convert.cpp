// storey convert LOG OUT_BAG: a CARMEN/GMapping log as a rosbag2 bag (/<robot>/scan,
// /<robot>/odom, /tf_static) that storey and ROS 2 can replay.
#include <iostream>
#include <limits>

#include "args.h"
#include "storey/common/log.h"
#include "storey/io/carmen.h"
#include "storey/runtime/sensor_bag.h"

namespace storey::cli {

extern const char* const summary_convert =
    "convert a CARMEN/GMapping log into a rosbag2 bag (scan, odom)";

int run_convert(Args& args) {
  args.usage(
          "LOG OUT_BAG",
          "Writes the scans of a CARMEN log (FLASER, RLASER, ROBOTLASER, RAWLASER; plain or .gz)\n"
          "or a GMapping .gfs log to a new rosbag2 folder: /<robot>/scan (sensor_msgs/LaserScan),\n"
          "/<robot>/odom (nav_msgs/Odometry) and the laser mounting on /tf_static.\n"
          "--odom scans pairs every scan with the odometry pose on its own line (in corrected\n"
          "logs that is the corrected pose); --odom lines writes the log's ODOM lines instead,\n"
          "dropping those stamped zero. Stamps are the log's own plus --stamp-offset; some logs\n"
          "have broken laser stamps (infinite-corridor: 2^32; csail: 6 digits), for which\n"
          "--restamp HZ numbers the scans at a fixed rate instead. A negative stamp is an error.")
      .option("robot", "NAME", "robot namespace of the topics", "robot")
      .option("laser", "ID", "laser to convert: 1 front, 2 rear, ..., 0 every laser", "1")
      .option("odom", "scans|lines", "odometry from each scan line, or the ODOM lines", "scans")
      .option("stamp-offset", "S", "seconds added to every stamp", "0")
      .option("restamp", "HZ", "stamp scan k at k/HZ s (+ offset) instead of its own (0: off)", "0")
      .option("storage", "sqlite3|mcap", "the bag's storage (rosbag2's storage identifier)",
              "sqlite3")
      .flag("lenient", "skip malformed lines (counted) instead of stopping at the first");
  if (!args.parse()) return 0;
  const std::string log_path = args.positional(0, "LOG");
  const std::string bag_path = args.positional(1, "OUT_BAG");
  if (args.positionals().size() > 2) throw UsageError("too many arguments (see --help)");
  const std::string robot = args.get("robot");
  const long laser_id = args.getInt("laser");
  if (laser_id < 0 || laser_id > 4) throw UsageError("--laser must be 0..4");
  const std::string odom_source = args.get("odom");
  if (odom_source != "scans" && odom_source != "lines")
    throw UsageError("--odom must be scans or lines, got '" + odom_source + "'");
  const double offset = args.getDouble("stamp-offset");
  const double restamp = args.getDouble("restamp");
  if (!std::isfinite(offset)) throw UsageError("--stamp-offset must be finite");
  if (!(restamp >= 0.0) || !std::isfinite(restamp))
    throw UsageError("--restamp must be a rate in Hz, or 0");
  if (restamp > 0.0 && odom_source == "lines")
    throw UsageError("--restamp renumbers scans only: use it with --odom scans");
  runtime::robotTopic(robot, "scan");  // rejects a bad robot name before anything is written
  bag::BagWriterOptions bag_options;
  bag_options.storage = args.getChoice("storage", {bag::kStorageSqlite3, bag::kStorageMcap});

  io::CarmenReaderOptions reader_options;
  reader_options.strict = !args.flagSet("lenient");
  io::CarmenReader reader(log_path, reader_options);
  runtime::SensorBagWriter writer(bag_path, bag_options);

  std::size_t scans = 0, odometry = 0, zero_stamped = 0, not_increasing = 0;
  double last_scan_stamp = -std::numeric_limits<double>::infinity();
  auto stampOf = [&](double log_stamp, std::size_t line) {
    const double stamp = (restamp > 0.0 ? static_cast<double>(scans) / restamp : log_stamp) + offset;
    if (stamp < 0.0)
      throw std::runtime_error(common::str(log_path, ":", line, ": stamp ", stamp,
                                           " s is negative; bags need stamps >= 0 "
                                           "(see --stamp-offset and --restamp)"));
    return stamp;
  };
  io::CarmenRecord record;
  while (reader.next(&record)) {
    if (record.kind == io::CarmenRecordKind::kLaser) {
      io::CarmenLaser& laser = record.laser;
      if (laser_id != 0 && laser.laser_id != laser_id) continue;
      laser.scan.stamp = stampOf(laser.scan.stamp, record.line);
      not_increasing += laser.scan.stamp <= last_scan_stamp;
      last_scan_stamp = laser.scan.stamp;
      if (odom_source == "scans" && laser.has_pose) {
        sensor::OdometrySample odom;
        odom.stamp = laser.scan.stamp;
        odom.pose = laser.odom_pose;
        writer.write(robot, odom);
        ++odometry;
      }
      writer.write(robot, laser.scan);
      ++scans;
    } else if (record.kind == io::CarmenRecordKind::kOdometry && odom_source == "lines") {
      if (record.odometry.stamp == 0.0) {
        ++zero_stamped;  // a zero stamp is a logging fault, not the epoch
        continue;
      }
      record.odometry.stamp = stampOf(record.odometry.stamp, record.line);
      writer.write(robot, record.odometry);
      ++odometry;
    }
  }
  writer.close();
  common::logInfo(common::str(log_path, ": ", reader.stats().summary()));
  for (const std::string& problem : reader.stats().problems) common::logDebug(problem);
  if (scans == 0) common::logWarn(log_path + ": no scan of the selected laser in the log");
  if (not_increasing > 0)
    common::logWarn(common::str(log_path, ": ", not_increasing,
                                " scans are not later than the scan before (broken stamps?"
                                " --restamp HZ numbers them instead)"));
  std::cout << "wrote " << scans << " scans and " << odometry << " odometry messages to "
            << bag_path;
  if (zero_stamped > 0) std::cout << " (dropped " << zero_stamped << " ODOM lines stamped zero)";
  std::cout << "\n";
  return 0;
}

}  // namespace storey::cli
