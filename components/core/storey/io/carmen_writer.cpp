// CarmenWriter: CARMEN log lines written as the readers of carmen.cpp expect them.
#include <charconv>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include <zlib.h>

#include "storey/io/carmen.h"

namespace storey::io {

namespace {
void appendNumber(std::string* out, double value) {
  char buffer[64];
  // Shortest text that reads back to the same double.
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}
void appendRange(std::string* out, float value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}
void appendPose(std::string* out, const geometry::Pose2& pose) {
  for (double v : {pose.x(), pose.y(), pose.theta()}) {
    out->push_back(' ');
    appendNumber(out, v);
  }
}
}  // namespace

CarmenWriter::CarmenWriter(const std::string& path) : path_(path) {
  const bool gz = path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
  file_ = gzopen(path.c_str(), gz ? "wb6" : "wT");
  if (!file_) throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(errno));
}

CarmenWriter::~CarmenWriter() {
  try {
    close();
  } catch (...) {
  }
}

void CarmenWriter::writeLine(const std::string& line) {
  if (!file_) throw std::runtime_error(path_ + ": writing to a closed log");
  if (gzwrite(static_cast<gzFile>(file_), line.data(), static_cast<unsigned>(line.size())) !=
          static_cast<int>(line.size()) ||
      gzputc(static_cast<gzFile>(file_), '\n') != '\n')
    throw std::runtime_error(path_ + ": write failed");
}

void CarmenWriter::comment(const std::string& text) { writeLine("# " + text); }

void CarmenWriter::param(const std::string& name, const std::string& value, double stamp) {
  std::string line = "PARAM " + name + " " + value + " ";
  appendNumber(&line, stamp);
  line += " storey ";
  appendNumber(&line, stamp);
  writeLine(line);
}

void CarmenWriter::flaser(const CarmenLaser& laser, int laser_id) {
  std::string line = laser_id == 2 ? "RLASER " : "FLASER ";
  line += std::to_string(laser.scan.ranges.size());
  for (float r : laser.scan.ranges) {
    line.push_back(' ');
    appendRange(&line, r);
  }
  appendPose(&line, laser.laser_pose);
  appendPose(&line, laser.odom_pose);
  line.push_back(' ');
  appendNumber(&line, laser.scan.stamp);
  line += " storey ";
  appendNumber(&line, laser.scan.stamp);
  writeLine(line);
}

void CarmenWriter::robotLaser(const CarmenLaser& laser) {
  const sensor::LaserScan& scan = laser.scan;
  std::string line = "ROBOTLASER1 0 ";
  const double fov =
      scan.angle_increment * static_cast<double>(!scan.ranges.empty() ? scan.ranges.size() - 1 : 0);
  for (double v : {scan.angle_min, fov, scan.angle_increment, scan.range_max, 0.01, 0.0}) {
    appendNumber(&line, v);
    line.push_back(' ');
  }
  line += std::to_string(scan.ranges.size());
  for (float r : scan.ranges) {
    line.push_back(' ');
    appendRange(&line, r);
  }
  line += " " + std::to_string(laser.remissions.size());
  for (float e : laser.remissions) {
    line.push_back(' ');
    appendRange(&line, e);
  }
  appendPose(&line, laser.laser_pose);
  appendPose(&line, laser.odom_pose);
  line += " 0 0 0 0 0 ";
  appendNumber(&line, scan.stamp);
  line += " storey ";
  appendNumber(&line, scan.stamp);
  writeLine(line);
}

void CarmenWriter::odometry(const sensor::OdometrySample& odometry, double acceleration) {
  std::string line = "ODOM";
  appendPose(&line, odometry.pose);
  for (double v :
       {odometry.linear_velocity, odometry.angular_velocity, acceleration, odometry.stamp}) {
    line.push_back(' ');
    appendNumber(&line, v);
  }
  line += " storey ";
  appendNumber(&line, odometry.stamp);
  writeLine(line);
}

void CarmenWriter::laserReading(const CarmenLaser& laser) {
  std::string line = "LASER_READING " + std::to_string(laser.scan.ranges.size());
  for (float r : laser.scan.ranges) {
    line.push_back(' ');
    appendRange(&line, r);
  }
  appendPose(&line, laser.laser_pose);
  line.push_back(' ');
  appendNumber(&line, laser.scan.stamp);
  writeLine(line);
}

void CarmenWriter::close() {
  if (!file_) return;
  const int status = gzclose(static_cast<gzFile>(file_));
  file_ = nullptr;
  if (status != Z_OK)
    throw std::runtime_error(path_ + ": closing failed (zlib status " + std::to_string(status) +
                             ")");
}

}  // namespace storey::io
