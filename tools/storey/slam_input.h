// The input of `storey slam`: one robot's scans with their odometry, from a CARMEN or .gfs
// log or from a bag, and the reference poses when there are any.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "storey/detection/floor_detector.h"
#include "storey/geometry/pose2.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/input_sequencer.h"
#include "storey/sensor/laser_scan.h"

namespace storey::cli {

// What the front end runs on: scans with their odometry, and reference poses when known.
struct SlamInput {
  std::string source;  // "log: PATH" or "bag: PATH"
  std::vector<sensor::LaserScan> scans;
  std::vector<geometry::Pose2> odometry;
  std::vector<geometry::Pose2> reference;  // per scan, or empty
  double duration = 0.0;                   // s; 0 when the stamps do not tell
  std::string odometry_note;
  std::vector<detection::FloorEvent> floor_events;  // a bag's rides, by the floor detector
};

// A CARMEN or .gfs log: its poses are the reference, and ("simulated") the odometry is derived
// from them with seeded noise; otherwise the log's own ("recorded": the pose on each laser
// line; "stream": its ODOM lines interpolated at each scan's stamp, as the floor_mapper pairs
// them live), with the poses of `reference_log` (if given) as the reference.
SlamInput logInput(const std::string& path, const std::string& odometry_source,
                   const eval::OdometryNoise& noise, const std::string& noise_text,
                   std::uint64_t seed, const std::string& reference_log, long max_scans,
                   const mapping::InputSequencerOptions& sequencing);

// A bag: one robot's scans with its recorded odometry; as the reference, the ground truth at
// `truth_path` (a trajectory.csv or its folder) or the poses of `reference_log` (the CARMEN
// log `storey convert` made the bag from) at the scans' stamps; "" for none. What went wrong on the
// way is said on stderr, and what was read is mapped.
SlamInput bagInput(const std::string& bag_path, const std::string& robot,
                   const std::string& truth_path, const std::string& reference_log, long max_scans,
                   const mapping::InputSequencerOptions& sequencing,
                   const detection::FloorDetectorOptions& detector_options);

}  // namespace storey::cli
