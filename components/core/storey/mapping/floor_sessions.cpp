#include "storey/mapping/floor_sessions.h"

#include "storey/common/log.h"

namespace storey::mapping {

FloorSessions::FloorSessions(FloorSlamOptions options, std::string robot, int initial_floor,
                             double initial_height)
    : options_(std::move(options)), robot_(std::move(robot)), current_floor_(initial_floor) {
  floors_[initial_floor] =
      std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, initial_floor, initial_height);
}

ScanResult FloorSessions::addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
  if (in_transit_) {
    ScanResult r;
    r.status = ScanStatus::kSkipped;
    r.reason = "in transit";
    r.pose = current().currentPose();
    return r;
  }
  return current().addScan(scan, odometry);
}

void FloorSessions::beginTransit() {
  if (in_transit_) return;
  in_transit_ = true;
  exit_pose_[current_floor_] = current().currentPose();
}

void FloorSessions::endTransit(int floor_id, double floor_height) {
  if (!in_transit_) exit_pose_[current_floor_] = current().currentPose();
  in_transit_ = false;
  if (floor_id == current_floor_) {
    // Back where it started (an aborted ride): continue, but re-check the pose first.
    current().resumeAt(exit_pose_[floor_id]);
    return;
  }
  current().optimize();
  current_floor_ = floor_id;
  auto it = floors_.find(floor_id);
  if (it == floors_.end()) {
    common::logInfo(common::str("floor_sessions[", robot_, "]: new floor ", floor_id, " at ", floor_height, " m"));
    floors_[floor_id] = std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, floor_id, floor_height);
    return;
  }
  if (options_.relocalization.known_floor == "new_graph") {
    common::logInfo(common::str("floor_sessions[", robot_, "]: back on floor ", floor_id,
                                "; a new floor graph (the matcher aligns it)"));
    retired_.push_back(std::move(it->second));
    it->second = std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, floor_id, floor_height);
    return;
  }
  common::logInfo(common::str("floor_sessions[", robot_, "]: back on floor ", floor_id, "; relocalising"));
  it->second->resumeAt(exit_pose_.count(floor_id) ? exit_pose_[floor_id] : it->second->currentPose());
}

}  // namespace storey::mapping
