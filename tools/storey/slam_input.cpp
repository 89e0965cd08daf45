// The input of `storey slam`: a log's or a bag's scans with their odometry and reference.
#include "slam_input.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "args.h"
#include "storey/bag/bag_error.h"
#include "storey/common/log.h"
#include "storey/eval/trajectory.h"
#include "storey/io/carmen.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/runtime/sensor_bag.h"

namespace storey::cli {

using geometry::Pose2;

namespace {

// One robot's scans in a bag, each with its odometry interpolated at its stamp (as the
// floor_mapper component pairs them: mapping::InputSequencer), and the rides the floor
// detector finds in its pressure and IMU.
struct BagInput {
  std::string robot;
  std::vector<sensor::LaserScan> scans;
  std::vector<Pose2> odometry;
  std::size_t scans_without_odometry = 0;
  std::size_t out_of_order = 0;  // samples behind their topic's last stamp, dropped
  std::string truncated;         // why reading stopped early ("" when it did not)
  std::vector<detection::FloorEvent> floor_events;  // transits started and ended, in order
};

BagInput readBagInput(const std::string& path, const std::string& robot_option,
                      mapping::InputSequencerOptions sequencing,
                      const detection::FloorDetectorOptions& detector_options) {
  runtime::SensorBagReader reader(path);
  const std::vector<std::string> robots = reader.robots();
  BagInput input;
  if (!robot_option.empty()) {
    input.robot = robot_option;
  } else if (robots.size() == 1) {
    input.robot = robots.front();
  } else {
    std::string names;
    for (const auto& r : robots) names += (names.empty() ? "" : ", ") + r;
    throw UsageError(path + " holds " +
                     (robots.empty() ? std::string("no robot's sensors") : "robots " + names) +
                     ": name one with --robot");
  }
  if (std::find(robots.begin(), robots.end(), input.robot) == robots.end())
    throw UsageError("robot '" + input.robot + "' is not in " + path);

  // The detector runs here, in stamp order, before the scans are mapped: nothing to wait for.
  sequencing.wait_for_floor_detector = false;
  mapping::InputSequencer sequencer(
      sequencing,
      [&](const sensor::LaserScan& scan, const Pose2& odometry) {
        input.scans.push_back(scan);
        input.odometry.push_back(odometry);
      },
      [](const detection::FloorEvent&) {}, "storey slam");
  detection::FloorDetector detector{detector_options};
  runtime::SensorRecord record;
  try {
    while (reader.next(record)) {
      if (record.robot != input.robot) continue;
      std::visit(
          [&](const auto& sample) {
            using T = std::decay_t<decltype(sample)>;
            if constexpr (std::is_same_v<T, sensor::LaserScan>) {
              detector.addScan(sample);
              sequencer.addScan(sample);
            } else if constexpr (std::is_same_v<T, sensor::OdometrySample>) {
              detector.addOdometry(sample);
              sequencer.addOdometry(sample);
            } else if constexpr (std::is_same_v<T, sensor::PressureSample>) {
              detector.addPressure(sample);
            } else {
              detector.addImu(sample);
            }
          },
          record.data);
      for (const auto& e : detector.takeEvents())
        if (e.type != detection::FloorEventType::kProgress) input.floor_events.push_back(e);
    }
  } catch (const bag::BagError& e) {
    input.truncated = e.what();  // what was read before stays: map it
  }
  sequencer.flush();
  input.scans_without_odometry = sequencer.stats().scans_without_odometry;
  input.out_of_order = reader.stats().out_of_order;
  return input;
}

// `robot`'s ground-truth pose at each scan's stamp: the row of that stamp (the simulator
// writes one per scan), else interpolated between rows at most 1 s apart. A scan the
// truth does not cover is an error naming the file.
std::vector<Pose2> truthAtScans(std::vector<eval::PoseRow> rows, const std::string& robot,
                                const std::vector<sensor::LaserScan>& scans,
                                const std::string& file) {
  rows.erase(std::remove_if(rows.begin(), rows.end(),
                            [&](const eval::PoseRow& r) { return r.robot != robot; }),
             rows.end());
  std::stable_sort(rows.begin(), rows.end(), [](const eval::PoseRow& a, const eval::PoseRow& b) {
    return a.stamp < b.stamp;
  });
  std::vector<Pose2> poses;
  for (const auto& scan : scans) {
    const auto after =
        std::lower_bound(rows.begin(), rows.end(), scan.stamp,
                         [](const eval::PoseRow& r, double t) { return r.stamp < t; });
    constexpr double kSameStamp = 1e-6;
    if (after != rows.end() && after->stamp - scan.stamp <= kSameStamp) {
      poses.push_back(after->pose);
    } else if (after != rows.begin() && (after - 1)->stamp >= scan.stamp - kSameStamp) {
      poses.push_back((after - 1)->pose);
    } else if (after != rows.end() && after != rows.begin() &&
               after->stamp - (after - 1)->stamp <= 1.0) {
      const auto& a = *(after - 1);
      poses.push_back(geometry::interpolate(a.pose, after->pose,
                                            (scan.stamp - a.stamp) / (after->stamp - a.stamp)));
    } else {
      std::ostringstream why;
      why << file << ": no pose of robot '" << robot << "' at or around t=" << std::fixed
          << std::setprecision(3) << scan.stamp << " s (a scan's stamp)";
      throw std::runtime_error(why.str());
    }
  }
  return poses;
}

// A log's laser readings and ODOM lines, read leniently: shared logs carry odd lines that are
// skipped.
io::CarmenLog readLog(const std::string& path) {
  io::CarmenReaderOptions reader_options;
  reader_options.strict = false;
  return io::readCarmenLog(path, reader_options);
}
std::vector<io::CarmenLaser> readLogLasers(const std::string& path) { return readLog(path).lasers; }

}  // namespace

// A CARMEN or .gfs log: its poses are the reference, and ("simulated") the odometry is derived
// from them with seeded noise; otherwise the log's own ("recorded": the pose on each laser
// line; "stream": its ODOM lines interpolated at each scan's stamp, as the floor_mapper pairs
// them live), with the poses of `reference_log` (if given) as the reference.
SlamInput logInput(const std::string& path, const std::string& odometry_source,
                   const eval::OdometryNoise& noise, const std::string& noise_text,
                   std::uint64_t seed, const std::string& reference_log, long max_scans,
                   const mapping::InputSequencerOptions& sequencing) {
  const bool simulate_odometry = odometry_source == "simulated";
  SlamInput input;
  input.source = "log: " + path;
  io::CarmenLog log = readLog(path);
  std::vector<io::CarmenLaser>& lasers = log.lasers;
  if (max_scans > 0 && lasers.size() > static_cast<std::size_t>(max_scans))
    lasers.resize(max_scans);
  if (lasers.empty()) throw std::runtime_error(path + " holds no laser readings with poses");
  auto& scans = input.scans;
  std::vector<Pose2> log_poses;
  for (const auto& l : lasers) {
    scans.push_back(l.scan);
    log_poses.push_back(l.robotPose());
  }
  // Some shared logs have a few repeated or backward stamps (made monotone here), others
  // unusable ones (replaced by the scan index, and the log's duration is unknown).
  std::size_t backwards = 0;
  for (std::size_t i = 1; i < scans.size(); ++i)
    if (!(scans[i].stamp > scans[i - 1].stamp)) ++backwards;
  if (backwards * 20 < scans.size()) {
    for (std::size_t i = 1; i < scans.size(); ++i)
      scans[i].stamp = std::max(scans[i].stamp, scans[i - 1].stamp);
    input.duration = scans.back().stamp - scans.front().stamp;
    if (backwards > 0)
      std::cerr << "storey slam: " << backwards
                << " stamps repeat or go backwards; made monotone\n";
  } else {
    if (odometry_source == "stream")
      throw std::runtime_error(path +
                               ": the scans' stamps are not increasing, so --odometry stream "
                               "cannot pair them with the ODOM lines");
    std::cerr << "storey slam: the log's stamps are not increasing; using the scan index as time\n";
    for (std::size_t i = 0; i < scans.size(); ++i) scans[i].stamp = static_cast<double>(i);
  }
  if (simulate_odometry) {
    input.reference = log_poses;
    input.odometry = eval::simulateOdometry(log_poses, noise, seed);
    input.odometry_note = "simulated from the log's poses, noise " + noise_text +
                          " (translation fraction, deg per m, heading fraction), seed " +
                          std::to_string(seed);
  } else if (odometry_source == "recorded") {
    input.odometry = log_poses;
    input.odometry_note = "as recorded on the laser lines";
  }
  if (!reference_log.empty()) {
    const std::vector<io::CarmenLaser> ref = readLogLasers(reference_log);
    if (ref.size() < scans.size())
      throw std::runtime_error("the reference log " + reference_log + " has " +
                               std::to_string(ref.size()) + " scans, the log " +
                               std::to_string(scans.size()));
    input.reference.clear();
    for (std::size_t i = 0; i < scans.size(); ++i) input.reference.push_back(ref[i].robotPose());
  }
  if (odometry_source == "stream") {
    const std::vector<sensor::OdometrySample>& samples = log.odometry;
    if (samples.empty())
      throw std::runtime_error(path + " has no ODOM lines for --odometry stream");
    const auto paired = mapping::odometryAtScans(scans, samples, sequencing);
    // Scans without odometry near them are dropped, with their reference poses.
    std::vector<sensor::LaserScan> kept_scans;
    std::vector<Pose2> kept_reference;
    for (std::size_t i = 0; i < scans.size(); ++i) {
      if (!paired[i]) continue;
      kept_scans.push_back(std::move(scans[i]));
      input.odometry.push_back(*paired[i]);
      if (!input.reference.empty()) kept_reference.push_back(input.reference[i]);
    }
    if (kept_scans.size() < scans.size())
      std::cerr << "storey slam: " << scans.size() - kept_scans.size()
                << " scans had no ODOM line within " << sequencing.max_odometry_gap
                << " s and were dropped\n";
    if (kept_scans.empty()) throw std::runtime_error(path + ": no scan has an ODOM line near it");
    scans = std::move(kept_scans);
    if (!input.reference.empty()) input.reference = std::move(kept_reference);
    input.odometry_note = "the log's ODOM lines at each scan's stamp (" +
                          std::to_string(samples.size()) + " samples)";
  }
  return input;
}

// A bag: one robot's scans with its recorded odometry; as the reference, the ground truth at
// `truth_path` (a trajectory.csv or its folder) or the poses of `reference_log` (the CARMEN
// log `storey convert` made the bag from) at the scans' stamps; "" for none. What went wrong on the
// way is said on stderr, and what was read is mapped.
SlamInput bagInput(const std::string& bag_path, const std::string& robot,
                   const std::string& truth_path, const std::string& reference_log, long max_scans,
                   const mapping::InputSequencerOptions& sequencing,
                   const detection::FloorDetectorOptions& detector_options) {
  BagInput bag = readBagInput(bag_path, robot, sequencing, detector_options);
  if (!bag.truncated.empty())
    std::cerr << "storey slam: " << bag.truncated << "; mapping the " << bag.scans.size()
              << " scans read before it\n";
  if (bag.out_of_order > 0)
    std::cerr << "storey slam: " << bag.out_of_order
              << " samples stamped before their topic's last were dropped\n";
  if (bag.scans_without_odometry > 0)
    std::cerr << "storey slam: " << bag.scans_without_odometry << " scans had no odometry within "
              << sequencing.max_odometry_gap << " s and were dropped\n";
  if (max_scans > 0 && bag.scans.size() > static_cast<std::size_t>(max_scans)) {
    bag.scans.resize(max_scans);
    bag.odometry.resize(max_scans);
  }
  if (bag.scans.empty())
    throw std::runtime_error(bag_path + " holds no scans of " + bag.robot + " with odometry");
  SlamInput input;
  input.source = "bag: " + bag_path;
  input.scans = std::move(bag.scans);
  input.odometry = std::move(bag.odometry);
  input.duration = input.scans.back().stamp - input.scans.front().stamp;
  input.odometry_note = "recorded in the bag (robot " + bag.robot + ")";
  input.floor_events = std::move(bag.floor_events);
  if (!truth_path.empty()) {
    const std::string csv = std::filesystem::is_directory(truth_path)
                                ? (std::filesystem::path(truth_path) / "trajectory.csv").string()
                                : truth_path;
    input.reference = truthAtScans(eval::readTrajectoryCsv(csv), bag.robot, input.scans, csv);
  } else if (!reference_log.empty()) {
    std::vector<eval::PoseRow> rows;
    for (const auto& l : readLogLasers(reference_log)) {
      eval::PoseRow row;
      row.stamp = l.scan.stamp;
      row.robot = bag.robot;
      row.pose = l.robotPose();
      rows.push_back(row);
    }
    input.reference = truthAtScans(std::move(rows), bag.robot, input.scans, reference_log);
  }
  return input;
}

}  // namespace storey::cli
