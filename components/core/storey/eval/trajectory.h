// Trajectories as CSV tables, `stamp,robot,floor,x,y,theta,z` (one pose per row, building
// frame, theta in radians), the format of the simulator's ground truth and of results.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "storey/geometry/pose2.h"

namespace storey::eval {

struct PoseRow {
  double stamp = 0.0;
  std::string robot;
  std::string floor;
  geometry::Pose2 pose;
  double z = 0.0;
};

// Thrown for a malformed table; what() reads "file:line: column: problem".
class TrajectoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::vector<PoseRow> readTrajectoryCsv(const std::string& path);
std::vector<PoseRow> parseTrajectoryCsv(const std::string& text, const std::string& name);
void writeTrajectoryCsv(const std::string& path, const std::vector<PoseRow>& rows);

}  // namespace storey::eval
