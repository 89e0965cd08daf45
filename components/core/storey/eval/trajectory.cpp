#include "storey/eval/trajectory.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace storey::eval {
namespace {

constexpr const char* kHeader = "stamp,robot,floor,x,y,theta,z";
constexpr const char* kColumns[] = {"stamp", "robot", "floor", "x", "y", "theta", "z"};

[[noreturn]] void fail(const std::string& name, int line, const std::string& column,
                       const std::string& problem) {
  std::ostringstream out;
  out << name << ":" << line << ": ";
  if (!column.empty()) out << column << ": ";
  out << problem;
  throw TrajectoryError(out.str());
}

double number(const std::string& text, const std::string& name, int line, const char* column) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(begin, &end);
  if (text.empty() || end != begin + text.size() || errno == ERANGE || !std::isfinite(value))
    fail(name, line, column, "expected a finite number, got '" + text + "'");
  return value;
}

}  // namespace

std::vector<PoseRow> parseTrajectoryCsv(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  std::string line;
  int number_of_line = 0;
  std::vector<PoseRow> rows;
  bool header = false;
  while (std::getline(in, line)) {
    ++number_of_line;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      if (line != kHeader)
        fail(name, number_of_line, "", std::string("expected the header '") + kHeader + "'");
      header = true;
      continue;
    }
    std::vector<std::string> fields;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) fields.push_back(cell);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    if (fields.size() != 7)
      fail(name, number_of_line, "", "expected 7 columns, got " + std::to_string(fields.size()));
    PoseRow row;
    row.stamp = number(fields[0], name, number_of_line, kColumns[0]);
    row.robot = fields[1];
    row.floor = fields[2];
    if (row.robot.empty()) fail(name, number_of_line, "robot", "empty");
    if (row.floor.empty()) fail(name, number_of_line, "floor", "empty");
    row.pose = geometry::Pose2(number(fields[3], name, number_of_line, kColumns[3]),
                               number(fields[4], name, number_of_line, kColumns[4]),
                               number(fields[5], name, number_of_line, kColumns[5]));
    row.z = number(fields[6], name, number_of_line, kColumns[6]);
    rows.push_back(row);
  }
  if (!header)
    fail(name, number_of_line, "",
         std::string("empty table: expected the header '") + kHeader + "'");
  return rows;
}

std::vector<PoseRow> readTrajectoryCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw TrajectoryError(path + ": cannot open file");
  std::stringstream text;
  text << in.rdbuf();
  return parseTrajectoryCsv(text.str(), path);
}

void writeTrajectoryCsv(const std::string& path, const std::vector<PoseRow>& rows) {
  std::ofstream out(path);
  if (!out) throw TrajectoryError(path + ": cannot write file");
  out << kHeader << "\n";
  char buffer[256];
  for (const auto& r : rows) {
    std::snprintf(buffer, sizeof(buffer), "%.6f,%s,%s,%.6f,%.6f,%.9f,%.6f\n", r.stamp,
                  r.robot.c_str(), r.floor.c_str(), r.pose.x(), r.pose.y(), r.pose.theta(), r.z);
    out << buffer;
  }
  if (!out) throw TrajectoryError(path + ": cannot write file");
}

}  // namespace storey::eval
