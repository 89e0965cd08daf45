// One robot's floor graphs: the front end of the floor it is on, and the graphs of the
// floors it has left. A ride (floor event) pauses mapping; arriving on a new floor opens a
// new graph, arriving on a known floor resumes its graph after localising in its map
// around where the robot left it, or (the default) opens a new graph of that floor for
// the floor matcher to align (relocalization.known_floor).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "storey/mapping/floor_slam.h"

namespace storey::mapping {

class FloorSessions {
 public:
  FloorSessions(FloorSlamOptions options, std::string robot, int initial_floor = 0,
                double initial_height = 0.0);

  // Passes the scan to the current floor's front end; while in transit, scans are
  // ignored (returned as kSkipped with the reason "in transit").
  ScanResult addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);

  // A ride or stair climb started: stop mapping until it ends.
  void beginTransit();
  // It ended on `floor_id`. The same floor resumes as it was; another floor is opened or
  // resumed (after relocalisation).
  void endTransit(int floor_id, double floor_height);

  bool inTransit() const { return in_transit_; }
  int currentFloor() const { return current_floor_; }
  FloorSlam& current() { return *floors_.at(current_floor_); }
  const FloorSlam& current() const { return *floors_.at(current_floor_); }
  // The graph each floor is mapped into now (one per floor id).
  const std::map<int, std::unique_ptr<FloorSlam>>& floors() const { return floors_; }
  // Earlier graphs of floors visited again (relocalization.known_floor: new_graph).
  const std::vector<std::unique_ptr<FloorSlam>>& retired() const { return retired_; }

 private:
  FloorSlamOptions options_;
  std::string robot_;
  std::map<int, std::unique_ptr<FloorSlam>> floors_;
  std::vector<std::unique_ptr<FloorSlam>> retired_;
  std::map<int, geometry::Pose2> exit_pose_;  // where the robot left each floor
  int current_floor_ = 0;
  int next_graph_id_ = 0;
  bool in_transit_ = false;
};

}  // namespace storey::mapping
