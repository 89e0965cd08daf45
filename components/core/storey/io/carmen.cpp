#include "storey/io/carmen.h"

#include <zlib.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string_view>

#include "storey/common/file_checks.h"
#include "storey/common/log.h"

namespace storey::io {
namespace {

constexpr std::size_t kInitialLineCapacity = 1 << 16;

std::string formatError(const std::string& file, std::size_t line, const std::string& problem) {
  std::ostringstream out;
  out << file;
  if (line > 0) out << ":" << line;
  out << ": " << problem;
  return out.str();
}

// A parse failure inside one line: `reason` is a short category for the statistics.
struct LineError {
  std::string reason;
  std::string message;
};

bool parseNumber(std::string_view token, double* value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto result = std::from_chars(token.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end;
}

class Tokens {
 public:
  Tokens(const std::vector<std::string_view>& tokens, std::size_t start)
      : tokens_(tokens), pos_(start) {}
  std::size_t remaining() const { return tokens_.size() - pos_; }
  std::size_t position() const { return pos_; }

  // A number that must be finite (poses, stamps, angles).
  double finite(const char* what) {
    const std::string_view token = take(what);
    double value;
    if (!parseNumber(token, &value))
      throw LineError{"not a number", str(what, " is not a number: '", token, "'")};
    if (!std::isfinite(value))
      throw LineError{"non-finite value", str(what, " must be finite, got '", token, "'")};
    return value;
  }
  // A number where NaN and infinities are meaningful (ranges: no return).
  double any(const char* what) {
    const std::string_view token = take(what);
    double value;
    if (!parseNumber(token, &value))
      throw LineError{"not a number", str(what, " is not a number: '", token, "'")};
    return value;
  }
  std::size_t count(const char* what) {
    const std::string_view token = take(what);
    long value = 0;
    const char* end = token.data() + token.size();
    const auto result = std::from_chars(token.data(), end, value);
    if (result.ec != std::errc() || result.ptr != end || value < 0 || value > 100000)
      throw LineError{"bad count", str(what, " is not a valid count: '", token, "'")};
    return static_cast<std::size_t>(value);
  }
  std::string_view word(const char* what) { return take(what); }

  template <typename... Args>
  static std::string str(const Args&... args) {
    std::ostringstream out;
    (out << ... << args);
    return out.str();
  }

 private:
  std::string_view take(const char* what) {
    if (pos_ >= tokens_.size()) throw LineError{"truncated line", str("line ends before ", what)};
    return tokens_[pos_++];
  }
  const std::vector<std::string_view>& tokens_;
  std::size_t pos_;
};

// Optional "host logger_stamp" tail: 0 or 2 tokens left.
void readTail(Tokens& t, CarmenRecord* record, const char* type) {
  if (t.remaining() == 0) {
    record->host.clear();
    record->logger_stamp = 0.0;
    return;
  }
  if (t.remaining() != 2)
    throw LineError{"wrong token count",
                    Tokens::str(type, " has ", t.remaining(),
                                " tokens after the stamp (expected 0 or 2: host logger_stamp)")};
  record->host.assign(t.word("host"));
  record->logger_stamp = t.finite("logger stamp");
}

// Default angles of a laser line without its own: the CARMEN convention for SICK scanners.
// An odd count (181, 361, 401) spans the field of view with both ends included; an even
// count (180, 360) is that many beams of fov/n starting at -fov/2.
void setDefaultAngles(sensor::LaserScan* scan, double fov) {
  const std::size_t n = scan->ranges.size();
  scan->angle_min = -0.5 * fov;
  if (n <= 1)
    scan->angle_increment = fov;
  else
    scan->angle_increment =
        (n % 2 == 1) ? fov / static_cast<double>(n - 1) : fov / static_cast<double>(n);
}

void readRanges(Tokens& t, std::size_t n, std::vector<float>* out) {
  out->resize(n);
  for (std::size_t i = 0; i < n; ++i) (*out)[i] = static_cast<float>(t.any("a range"));
}

}  // namespace

CarmenError::CarmenError(const std::string& file, std::size_t line, const std::string& problem)
    : std::runtime_error(formatError(file, line, problem)),
      file_(file),
      line_(line),
      problem_(problem) {}

CarmenReaderOptions readCarmenReaderOptions(const common::ConfigNode& node) {
  CarmenReaderOptions o;
  o.strict = node.get<bool>("strict", o.strict);
  o.default_fov = node.getDouble("default_fov", o.default_fov, 1e-3, 2 * M_PI);
  o.default_range_max = node.getDouble("default_range_max", o.default_range_max, 0.1, 1000.0);
  o.range_min = node.getDouble("range_min", o.range_min, 0.0, 100.0);
  o.max_problems_kept = static_cast<std::size_t>(
      node.getInt("max_problems_kept", static_cast<int>(o.max_problems_kept), 0, 100000));
  node.finish();
  if (o.range_min >= o.default_range_max) node.fail("range_min", "must be below default_range_max");
  return o;
}

std::size_t CarmenStats::recordCount(const std::string& type) const {
  const auto it = records.find(type);
  return it == records.end() ? 0 : it->second;
}

std::size_t CarmenStats::unknownCount() const {
  std::size_t n = 0;
  for (const auto& [type, count] : unknown) n += count;
  return n;
}

std::string skippedLinesNote(const std::string& path, const CarmenStats& stats) {
  if (stats.skipped == 0 && stats.unknown.empty()) return "";
  std::ostringstream out;
  out << path << ": " << stats.skipped + stats.unknownCount() << " lines skipped (" << stats.skipped
      << " unreadable, " << stats.unknownCount() << " of unknown types)";
  if (!stats.first_skipped.empty()) out << "; first unreadable: " << stats.first_skipped;
  return out.str();
}

std::string CarmenStats::summary() const {
  std::ostringstream out;
  out << lines << " lines (" << bytes << " bytes), " << comments << " comments";
  for (const auto& [type, count] : records) out << ", " << count << " " << type;
  if (!unknown.empty()) {
    out << "; skipped unknown:";
    for (const auto& [type, count] : unknown) out << " " << count << " " << type;
  }
  if (skipped > 0) {
    out << "; skipped malformed: " << skipped << " (";
    bool first = true;
    for (const auto& [reason, count] : skip_reasons) {
      out << (first ? "" : ", ") << count << " " << reason;
      first = false;
    }
    out << ")";
  }
  if (zero_stamps > 0 || out_of_order_stamps > 0)
    out << "; stamps: " << zero_stamps << " zero, " << out_of_order_stamps << " out of order";
  return out.str();
}

struct CarmenReader::Impl {
  gzFile file = nullptr;
  std::string line;
  std::vector<char> buffer;
  std::vector<std::string_view> tokens;
  std::size_t line_number = 0;
  bool params_dirty = true;
  // Per laser id (index 1..4): field of view, range max, sensor offset from PARAMs.
  struct LaserDefaults {
    double fov = M_PI;
    double range_max = 80.0;
    geometry::Pose2 offset;
  };
  LaserDefaults defaults[5];

  ~Impl() {
    if (file) gzclose(file);
  }
};

CarmenReader::CarmenReader(const std::string& path, const CarmenReaderOptions& options)
    : path_(path), options_(options), impl_(std::make_unique<Impl>()) {
  try {
    common::requireRegularFile(path, "CARMEN log");  // gzopen would block on a FIFO
  } catch (const std::runtime_error& e) {
    throw CarmenError(path, 0, std::string(e.what()).substr(path.size() + 2));
  }
  // gzopen reads plain files transparently, so one code path serves both.
  impl_->file = gzopen(path.c_str(), "rb");
  if (!impl_->file)
    throw CarmenError(path, 0, "cannot open the log: " + std::string(std::strerror(errno)));
  gzbuffer(impl_->file, 1 << 18);
  impl_->buffer.resize(kInitialLineCapacity);
  // An empty log is almost always a mistake (wrong file, failed recording).
  const int c = gzgetc(impl_->file);
  if (c == -1) {
    int err = Z_OK;
    const char* message = gzerror(impl_->file, &err);
    if (err != Z_OK && err != Z_STREAM_END)
      throw CarmenError(path, 0, std::string("cannot read the log: ") + message);
    if (options_.strict) throw CarmenError(path, 0, "the log is empty");
  } else {
    gzungetc(c, impl_->file);
  }
}

CarmenReader::~CarmenReader() = default;

std::optional<double> CarmenReader::paramDouble(const std::string& name) const {
  const auto it = params_.find(name);
  if (it == params_.end()) return std::nullopt;
  double value;
  if (!parseNumber(it->second, &value) || !std::isfinite(value)) return std::nullopt;
  return value;
}

bool CarmenReader::readLine() {
  Impl& s = *impl_;
  s.line.clear();
  bool got = false;
  while (true) {
    char* result = gzgets(s.file, s.buffer.data(), static_cast<int>(s.buffer.size()));
    if (!result) {
      int err = Z_OK;
      const char* message = gzerror(s.file, &err);
      if (err != Z_OK && err != Z_STREAM_END && err != Z_BUF_ERROR)
        throw CarmenError(path_, s.line_number + 1, std::string("read error: ") + message);
      // Z_BUF_ERROR: the gzip stream ends early (a truncated download). Keep what was read.
      if (err == Z_BUF_ERROR)
        noteProblem("truncated gzip stream", "the gzip stream ends unexpectedly");
      break;
    }
    got = true;
    const std::size_t length = std::strlen(result);
    if (s.line.size() + length > kMaxLineBytes)
      throw CarmenError(
          path_, s.line_number + 1,
          "line longer than " + std::to_string(kMaxLineBytes) + " bytes (not a CARMEN log?)");
    s.line.append(result, length);
    if (length > 0 && result[length - 1] == '\n') break;
    // Shorter than the buffer without a newline: the last line of a file that does not end in
    // one. A full buffer: the line is longer than the buffer; read on and append.
    if (length + 1 < s.buffer.size()) break;
  }
  if (!got) return false;
  ++s.line_number;
  ++stats_.lines;
  stats_.bytes += s.line.size();
  while (!s.line.empty() && (s.line.back() == '\n' || s.line.back() == '\r')) s.line.pop_back();
  return true;
}

void CarmenReader::noteProblem(const std::string& reason, const std::string& message) {
  (void)reason;
  if (stats_.problems.size() < options_.max_problems_kept)
    stats_.problems.push_back(formatError(path_, impl_->line_number, message));
}

void CarmenReader::checkStamp(const std::string& type, double stamp) {
  if (stamp == 0.0) {
    ++stats_.zero_stamps;
    noteProblem("zero stamp", type + " stamp is zero");
    return;  // a zero stamp says nothing about order
  }
  auto [it, inserted] = last_stamp_.emplace(type, stamp);
  if (!inserted) {
    if (stamp < it->second) {
      ++stats_.out_of_order_stamps;
      std::ostringstream message;
      message << std::setprecision(15) << type << " stamp " << stamp
              << " is earlier than the previous " << it->second;
      noteProblem("out-of-order stamp", message.str());
    }
    it->second = stamp;
  }
}

std::string CarmenReader::parseLine(CarmenRecord* record, bool* known) {
  Impl& s = *impl_;
  *known = true;
  s.tokens.clear();
  const char* p = s.line.data();
  const char* end = p + s.line.size();
  while (p < end) {
    while (p < end && (*p == ' ' || *p == '\t')) ++p;
    const char* start = p;
    while (p < end && *p != ' ' && *p != '\t') ++p;
    if (p > start) s.tokens.emplace_back(start, static_cast<std::size_t>(p - start));
  }
  const std::string_view type = s.tokens.front();

  if (s.params_dirty) {
    // PARAM values that shape laser lines without their own angles and limits.
    auto fov = [&](const char* name) {
      const auto v = paramDouble(name);
      if (!v || *v <= 0) return options_.default_fov;
      return *v > 2 * M_PI + 1e-6 ? *v * M_PI / 180.0 : *v;  // some logs give degrees
    };
    auto range = [&](const char* name) {
      if (const auto v = paramDouble(name); v && *v > 0) return *v;
      if (const auto v = paramDouble("maxrange"); v && *v > 0) return *v;  // GMapping .gfs
      return options_.default_range_max;
    };
    s.defaults[1].fov = fov("laser_front_laser_fov");
    s.defaults[1].range_max = range("robot_front_laser_max");
    s.defaults[1].offset =
        geometry::Pose2(paramDouble("robot_frontlaser_offset").value_or(0.0), 0, 0);
    s.defaults[2].fov = fov("laser_rear_laser_fov");
    s.defaults[2].range_max = range("robot_rear_laser_max");
    s.defaults[2].offset =
        geometry::Pose2(-paramDouble("robot_rearlaser_offset").value_or(0.0), 0, M_PI);
    s.params_dirty = false;
  }

  try {
    Tokens t(s.tokens, 1);
    record->type.assign(type);
    record->line = s.line_number;
    if (type == "FLASER" || type == "RLASER" || type == "LASER_READING") {
      const bool gfs = type == "LASER_READING";
      const int id = type == "RLASER" ? 2 : 1;
      CarmenLaser& laser = record->laser;
      const std::size_t n = t.count("the number of readings");
      const std::size_t expected_short = n + (gfs ? 4 : 7), expected_long = n + 9;
      if (t.remaining() != expected_short && (gfs || t.remaining() != expected_long))
        throw LineError{"wrong token count",
                        Tokens::str(type, " with ", n, " readings needs ", expected_short,
                                    gfs ? "" : Tokens::str(" or ", expected_long),
                                    " tokens after the count, found ", t.remaining())};
      readRanges(t, n, &laser.scan.ranges);
      laser.laser_id = id;
      laser.has_pose = true;
      const double x = t.finite("x"), y = t.finite("y"), theta = t.finite("theta");
      laser.laser_pose = geometry::Pose2(x, y, theta);
      if (gfs) {
        laser.odom_pose = laser.laser_pose;
      } else {
        const double ox = t.finite("odom_x"), oy = t.finite("odom_y"),
                     otheta = t.finite("odom_theta");
        laser.odom_pose = geometry::Pose2(ox, oy, otheta);
      }
      laser.scan.stamp = t.finite("stamp");
      readTail(t, record, record->type.c_str());
      setDefaultAngles(&laser.scan, s.defaults[id].fov);
      laser.scan.range_min = options_.range_min;
      laser.scan.range_max = s.defaults[id].range_max;
      laser.scan.sensor_offset = gfs ? geometry::Pose2() : s.defaults[id].offset;
      laser.remissions.clear();
      record->kind = CarmenRecordKind::kLaser;
      checkStamp(record->type, laser.scan.stamp);
    } else if ((type.size() == 11 && type.substr(0, 10) == "ROBOTLASER" &&
                (type[10] == '1' || type[10] == '2')) ||
               (type.size() == 9 && type.substr(0, 8) == "RAWLASER" && type[8] >= '1' &&
                type[8] <= '4')) {
      const bool robot = type[0] == 'R' && type[1] == 'O';
      CarmenLaser& laser = record->laser;
      laser.laser_id = type.back() - '0';
      t.word("laser type");
      const double start = t.finite("start_angle"), fov = t.finite("field_of_view");
      const double resolution = t.finite("angular_resolution"),
                   max_range = t.finite("maximum_range");
      t.finite("accuracy");
      t.finite("remission_mode");
      (void)fov;
      const std::size_t n = t.count("the number of readings");
      if (t.remaining() < n + 1)
        throw LineError{"wrong token count",
                        Tokens::str(type, " declares ", n, " readings but has only ",
                                    t.remaining() == 0 ? 0 : t.remaining() - 1)};
      readRanges(t, n, &laser.scan.ranges);
      const std::size_t m = t.count("the number of remissions");
      const std::size_t tail = robot ? 12 : 1;
      if (t.remaining() != m + tail && t.remaining() != m + tail + 2)
        throw LineError{
            "wrong token count",
            Tokens::str(type, " with ", m, " remissions needs ", m + tail, " or ", m + tail + 2,
                        " tokens after the remission count, found ", t.remaining())};
      laser.remissions.resize(m);
      for (std::size_t i = 0; i < m; ++i)
        laser.remissions[i] = static_cast<float>(t.any("a remission"));
      laser.scan.angle_min = start;
      laser.scan.angle_increment = resolution;
      laser.scan.range_min = options_.range_min;
      laser.scan.range_max = max_range;
      laser.scan.sensor_offset = geometry::Pose2();
      laser.has_pose = robot;
      if (robot) {
        const double lx = t.finite("laser_x"), ly = t.finite("laser_y"),
                     lt = t.finite("laser_theta");
        const double rx = t.finite("robot_x"), ry = t.finite("robot_y"),
                     rt = t.finite("robot_theta");
        laser.laser_pose = geometry::Pose2(lx, ly, lt);
        laser.odom_pose = geometry::Pose2(rx, ry, rt);
        laser.scan.sensor_offset = laser.odom_pose.between(laser.laser_pose);
        for (const char* what :
             {"tv", "rv", "forward_safety_dist", "side_safety_dist", "turn_axis"})
          t.finite(what);
      } else {
        laser.laser_pose = laser.odom_pose = geometry::Pose2();
      }
      laser.scan.stamp = t.finite("stamp");
      readTail(t, record, record->type.c_str());
      if (const std::string why = laser.scan.validate(); !why.empty())
        throw LineError{"invalid scan", why};
      record->kind = CarmenRecordKind::kLaser;
      checkStamp(record->type, laser.scan.stamp);
    } else if (type == "ODOM") {
      sensor::OdometrySample& odom = record->odometry;
      const std::size_t count = t.remaining();
      if (count != 4 && count != 7 && count != 9)
        throw LineError{"wrong token count",
                        Tokens::str("ODOM needs 4 (.gfs), 7 or 9 tokens, found ", count)};
      const double x = t.finite("x"), y = t.finite("y"), theta = t.finite("theta");
      odom.pose = geometry::Pose2(x, y, theta);
      if (count == 4) {
        odom.linear_velocity = odom.angular_velocity = 0.0;
        record->odometry_acceleration = 0.0;
      } else {
        odom.linear_velocity = t.finite("tv");
        odom.angular_velocity = t.finite("rv");
        record->odometry_acceleration = t.finite("accel");
      }
      odom.z = 0.0;
      odom.stamp = t.finite("stamp");
      readTail(t, record, "ODOM");
      record->kind = CarmenRecordKind::kOdometry;
      checkStamp("ODOM", odom.stamp);
    } else if (type == "PARAM") {
      // Logs differ in what follows the value: nothing, "host logger_stamp", or
      // "stamp host logger_stamp".
      const std::size_t count = t.remaining();
      if (count != 2 && count != 4 && count != 5)
        throw LineError{
            "wrong token count",
            Tokens::str(
                "PARAM needs 'name value' and optionally '[stamp] host logger_stamp', found ",
                count, " tokens")};
      record->param_name.assign(t.word("the name"));
      record->param_value.assign(t.word("the value"));
      if (count == 5) t.finite("stamp");
      readTail(t, record, "PARAM");
      params_[record->param_name] = record->param_value;
      s.params_dirty = true;
      record->kind = CarmenRecordKind::kParam;
    } else {
      *known = false;
    }
  } catch (const LineError& error) {
    stats_.skip_reasons[error.reason]++;
    return error.message;
  }
  return "";
}

bool CarmenReader::next(CarmenRecord* record) {
  while (readLine()) {
    const std::string& line = impl_->line;
    std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos) {
      ++stats_.blank;
      continue;
    }
    if (line[first] == '#') {
      ++stats_.comments;
      continue;
    }
    bool known = true;
    const std::string problem = parseLine(record, &known);
    if (!known) {
      ++stats_.unknown[std::string(impl_->tokens.front())];
      continue;
    }
    if (!problem.empty()) {
      if (options_.strict) throw CarmenError(path_, impl_->line_number, problem);
      ++stats_.skipped;
      noteProblem("malformed", problem);
      if (stats_.first_skipped.empty())
        stats_.first_skipped = formatError(path_, impl_->line_number, problem);
      continue;
    }
    ++stats_.records[record->type];
    return true;
  }
  return false;
}

CarmenLog readCarmenLog(const std::string& path, const CarmenReaderOptions& options) {
  CarmenReader reader(path, options);
  CarmenLog log;
  CarmenRecord record;
  while (reader.next(&record)) {
    if (record.kind == CarmenRecordKind::kLaser && record.laser.has_pose)
      log.lasers.push_back(record.laser);
    else if (record.kind == CarmenRecordKind::kOdometry)
      log.odometry.push_back(record.odometry);
  }
  log.stats = reader.stats();
  if (const std::string note = skippedLinesNote(path, log.stats); !note.empty())
    common::logWarn(note);
  return log;
}

std::vector<CarmenLaser> readCarmenLasers(const std::string& path,
                                          const CarmenReaderOptions& options) {
  return readCarmenLog(path, options).lasers;
}

}  // namespace storey::io
