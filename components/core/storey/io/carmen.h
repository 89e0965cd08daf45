// CARMEN laser logs (FLASER, RLASER, ROBOTLASER1/2, RAWLASER1..4, ODOM, PARAM, # comments)
// and the GMapping .gfs LASER_READING lines, read line by line from plain or gzip files
// (never the whole log in memory), converted to storey's sensor types. Also a writer for the
// same formats, so logs can be produced by storey and round-tripped in tests.
//
// Line layouts read (tokens separated by blanks; host and logger stamp are optional):
//   FLASER n r1..rn x y θ odom_x odom_y odom_θ stamp [host logger_stamp]    (RLASER alike)
//   ROBOTLASERk type start_angle fov resolution max_range accuracy remission_mode
//               n r1..rn m e1..em laser_x laser_y laser_θ robot_x robot_y robot_θ
//               tv rv forward_safety side_safety turn_axis stamp [host logger_stamp]
//   RAWLASERk   type start_angle fov resolution max_range accuracy remission_mode
//               n r1..rn m e1..em stamp [host logger_stamp]
//   ODOM x y θ tv rv accel stamp [host logger_stamp]      (CARMEN)
//   ODOM x y θ stamp                                      (GMapping .gfs)
//   LASER_READING n r1..rn x y θ stamp                    (GMapping .gfs: raw odometry pose)
//   PARAM name value [stamp host logger_stamp]
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/geometry/pose2.h"
#include "storey/sensor/laser_scan.h"

namespace storey::io {

// A malformed log line (or an unreadable file). what() reads "file:line: problem".
class CarmenError : public std::runtime_error {
 public:
  CarmenError(const std::string& file, std::size_t line, const std::string& problem);
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }  // 0 when the problem is the file itself
  const std::string& problem() const { return problem_; }

 private:
  std::string file_;
  std::size_t line_;
  std::string problem_;
};

// Longest line a log may have: a 1081-beam ROBOTLASER1 line with remissions is ~25 kB.
inline constexpr std::size_t kMaxLineBytes = 4u << 20;

struct CarmenReaderOptions {
  // strict: the first malformed line throws CarmenError, and an empty log is an error.
  // lenient: malformed lines are skipped and counted in stats(); an empty log reads as empty.
  bool strict = true;
  // FLASER/RLASER/LASER_READING carry no angles: the field of view comes from PARAM
  // laser_front_laser_fov / laser_rear_laser_fov when present, else this (radians).
  double default_fov = M_PI;
  // FLASER/RLASER/LASER_READING carry no range limit: PARAM robot_front_laser_max /
  // robot_rear_laser_max (or the .gfs PARAM maxrange) when present, else this (metres).
  // Readings at or beyond it are "no return" (SICK logs write 81.83 or 81.91 for those).
  double default_range_max = 80.0;
  double range_min = 0.01;             // readings below are "no return"
  std::size_t max_problems_kept = 20;  // the first problems kept as text in stats()
};
CarmenReaderOptions readCarmenReaderOptions(const common::ConfigNode& node);

enum class CarmenRecordKind { kLaser, kOdometry, kParam };

struct CarmenLaser {
  // 1 = front (FLASER, LASER_READING, ROBOTLASER1, RAWLASER1), 2 = rear (RLASER,
  // ROBOTLASER2, RAWLASER2), 3 and 4 for RAWLASER3/4.
  int laser_id = 1;
  // Stamp, angles (sensor frame), limits, ranges (NaN/inf kept: no return), and
  // sensor_offset: the laser's pose in the robot frame (ROBOTLASER: exact, from its two
  // poses; FLASER: PARAM robot_frontlaser_offset along x; RLASER: rear offset, facing back).
  sensor::LaserScan scan;
  bool has_pose = false;  // RAWLASER carries no pose
  // The pose the log gives for the laser: in *corrected* logs, the SLAM-corrected pose. For
  // LASER_READING this is the raw odometry pose (the .gfs line carries only that).
  geometry::Pose2 laser_pose;
  // The robot's odometry pose at the reading (FLASER odom_x.., ROBOTLASER robot_x..).
  geometry::Pose2 odom_pose;
  std::vector<float> remissions;  // ROBOTLASER/RAWLASER only

  // The robot's pose in laser_pose's frame: laser_pose with the sensor offset removed.
  geometry::Pose2 robotPose() const { return laser_pose * scan.sensor_offset.inverse(); }
};

struct CarmenRecord {
  CarmenRecordKind kind = CarmenRecordKind::kParam;
  std::string type;      // the line's keyword: "FLASER", "ODOM", "PARAM", ...
  std::size_t line = 0;  // 1-based line number in the log
  std::string host;      // "" when the line has none
  double logger_stamp = 0.0;
  CarmenLaser laser;                // kind == kLaser
  sensor::OdometrySample odometry;  // kind == kOdometry
  double odometry_acceleration = 0.0;
  std::string param_name, param_value;  // kind == kParam
};

struct CarmenStats {
  std::size_t lines = 0;     // lines read, including comments and blank lines
  std::size_t comments = 0;  // '#' lines
  std::size_t blank = 0;
  std::map<std::string, std::size_t> records;       // returned records per keyword
  std::map<std::string, std::size_t> unknown;       // skipped lines per unknown keyword
  std::size_t skipped = 0;                          // malformed lines skipped (lenient mode)
  std::map<std::string, std::size_t> skip_reasons;  // per kind of problem
  // Stamps that are zero or earlier than the previous stamp of the same keyword. These
  // lines are still returned: the shared logs have them and their data is fine otherwise.
  std::size_t zero_stamps = 0;
  std::size_t out_of_order_stamps = 0;
  std::vector<std::string> problems;  // "file:line: problem", the first few
  std::string first_skipped;          // "file:line: problem" of the first malformed line skipped
  std::size_t bytes = 0;              // uncompressed bytes read

  std::size_t recordCount(const std::string& type) const;
  std::size_t unknownCount() const;
  std::string summary() const;  // one human-readable paragraph
};

// "FILE: N lines skipped (U unreadable, K of unknown types); first: FILE:LINE: problem",
// or "" when none were.
std::string skippedLinesNote(const std::string& path, const CarmenStats& stats);

// Streams the records of one log. Unknown keywords are skipped and counted; PARAM lines
// are returned and also collected into params(), so later laser lines use them.
class CarmenReader {
 public:
  // Throws CarmenError when the file cannot be opened, or (strict) is empty.
  explicit CarmenReader(const std::string& path, const CarmenReaderOptions& options = {});
  ~CarmenReader();
  CarmenReader(const CarmenReader&) = delete;
  CarmenReader& operator=(const CarmenReader&) = delete;

  // The next record, reusing `record`'s storage; false at the end of the log. Strict mode
  // throws CarmenError for a malformed line; lenient mode skips it.
  bool next(CarmenRecord* record);

  const CarmenStats& stats() const { return stats_; }
  const std::map<std::string, std::string>& params() const { return params_; }
  std::optional<double> paramDouble(const std::string& name) const;
  const std::string& path() const { return path_; }
  const CarmenReaderOptions& options() const { return options_; }

 private:
  struct Impl;
  bool readLine();
  // Parses the current line into `record`; "" on success, else the problem.
  std::string parseLine(CarmenRecord* record, bool* known);
  void noteProblem(const std::string& reason, const std::string& message);
  void checkStamp(const std::string& type, double stamp);

  std::string path_;
  CarmenReaderOptions options_;
  std::unique_ptr<Impl> impl_;
  CarmenStats stats_;
  std::map<std::string, std::string> params_;
  std::map<std::string, double> last_stamp_;
};

// Every laser record of a log that has a pose (FLASER, RLASER, ROBOTLASER, LASER_READING)
// and every ODOM line, each in file order. Convenience for small logs and tests.
struct CarmenLog {
  std::vector<CarmenLaser> lasers;
  std::vector<sensor::OdometrySample> odometry;
  CarmenStats stats;
};
// A lenient read that skipped lines (malformed or of unknown types) says so in a warning
// naming the file, the counts and the first problem: nothing is dropped silently.
CarmenLog readCarmenLog(const std::string& path, const CarmenReaderOptions& options = {});
// Its lasers alone.
std::vector<CarmenLaser> readCarmenLasers(const std::string& path,
                                          const CarmenReaderOptions& options = {});

// Writes CARMEN logs (gzip when the path ends in ".gz"), with full float precision so
// that reading back gives the same values.
class CarmenWriter {
 public:
  explicit CarmenWriter(const std::string& path);  // throws std::runtime_error
  ~CarmenWriter();
  CarmenWriter(const CarmenWriter&) = delete;
  CarmenWriter& operator=(const CarmenWriter&) = delete;

  void comment(const std::string& text);
  void param(const std::string& name, const std::string& value, double stamp = 0.0);
  // FLASER (laser_id 1) or RLASER (laser_id 2) with the scan's ranges, both poses, stamp.
  void flaser(const CarmenLaser& laser, int laser_id = 1);
  // ROBOTLASER1 with the scan's own angles and limits.
  void robotLaser(const CarmenLaser& laser);
  void odometry(const sensor::OdometrySample& odometry, double acceleration = 0.0);
  // GMapping LASER_READING (the pose written is laser_pose).
  void laserReading(const CarmenLaser& laser);
  // Flushes and closes; throws std::runtime_error on a write error. Also run by the
  // destructor (which swallows errors).
  void close();

 private:
  void writeLine(const std::string& line);
  std::string path_;
  void* file_ = nullptr;  // gzFile
};

}  // namespace storey::io
