// FloorSessions on an arrival the height alone does not decide: the arriving scans are
// localised in every candidate floor's map, and the floor that holds them is the one reached.
#include <algorithm>
#include <cmath>

#include "storey/common/log.h"
#include "storey/mapping/floor_sessions.h"

namespace storey::mapping {

using common::str;

void FloorSessions::endTransit(const floor::FloorEvent& event) {
  if (!event.identityUnsure()) {
    endTransit(event.floor_id, event.floor_height, event.stamp);
    return;
  }
  ++stats_.unsure_arrivals;
  // The scans held through the ride are the cabin's (see endTransit): not used here.
  transit_scans_.clear();
  if (!in_transit_) exit_pose_[current_floor_] = current().currentPose();
  in_transit_ = false;
  if (relocalizer_) openNewGraphOfCurrentFloor("left again before localising");
  identify_ = std::make_unique<Identification>();
  identify_->event = event;
  identify_->left = current_floor_;
  identify_->check_left = std::find(event.candidate_floors.begin(), event.candidate_floors.end(),
                                    current_floor_) != event.candidate_floors.end();
  ++arrivals_;
  if (options_.relocalization.known_floor != "new_graph") {
    for (const int floor : event.candidate_floors) {
      const auto it = floors_.find(floor);
      if (it == floors_.end() || it->second->floorGraph().nodes.empty())
        continue;  // no map of it here
      identify_->relocalizers.emplace_back(floor, relocalizerFor(floor));
    }
  }
  std::string floors;
  for (const auto& [floor, r] : identify_->relocalizers)
    floors += (floors.empty() ? "" : ", ") + std::to_string(floor);
  common::logInfo(str(
      "floor_sessions[", robot_, "]: the ride that ended at ", event.stamp,
      " reached a floor its height does not decide (the detector chose ", event.floor_id,
      event.new_floor_id >= 0 ? str("; a new floor would be ", event.new_floor_id) : std::string(),
      "); localising in ",
      floors.empty() ? std::string("no candidate's map") : "floors " + floors));
  if (identify_->relocalizers.empty()) resolveIdentity(-1);
}

ScanResult FloorSessions::addIdentifyingScan(const sensor::LaserScan& scan,
                                             const geometry::Pose2& odometry) {
  ScanResult r;
  r.pose = current().currentPose();
  auto& buffer = identify_->buffer;
  if (rejectedForBuffer(scan, odometry, buffer.empty() ? -1e300 : buffer.back().scan.stamp, r))
    return r;
  if (identify_->check_left) {
    identify_->check_left = false;
    if (buffer.empty() && current().continuesHere(scan, odometry)) {
      const floor::FloorEvent e = identify_->event;
      identify_.reset();
      identities_.push_back({e.stamp, current_floor_, true});
      ++stats_.identified_by_map;
      common::logInfo(str("floor_sessions[", robot_, "]: the ride that ended at ", e.stamp,
                          " did not leave floor ", current_floor_,
                          " (the scans after it go on where tracking left off)"));
      return current().addScan(scan, odometry);
    }
  }
  buffer.push_back({scan, odometry});
  bool localized = false, searching = false;
  for (auto& [floor, relocalizer] : identify_->relocalizers) {
    if (relocalizer->status() == RelocalizationStatus::kSearching) relocalizer->add(scan, odometry);
    localized = localized || relocalizer->status() == RelocalizationStatus::kLocalized;
    searching = searching || relocalizer->status() == RelocalizationStatus::kSearching;
  }
  const int winner = localized ? uniqueCandidate() : -1;
  if (winner < 0 && localized) {
    // Floors alike where the robot is: localise again from the next scans on, which reach
    // further (the robot leaves the lift lobby every floor shares).
    for (auto& [floor, relocalizer] : identify_->relocalizers) {
      if (relocalizer->status() != RelocalizationStatus::kLocalized) continue;
      relocalizer = relocalizerFor(floor, ++identify_->restarts);
      searching = true;
    }
  }
  if (winner < 0 && searching) {
    r.status = ScanStatus::kSkipped;
    r.reason = "identifying the floor";
    return r;
  }
  r = resolveIdentity(winner);
  r.relocalized = r.matched = winner >= 0;
  return r;
}

void FloorSessions::decideIdentity() {
  if (!identify_) return;
  for (auto& [floor, relocalizer] : identify_->relocalizers)
    if (relocalizer->status() == RelocalizationStatus::kSearching) relocalizer->decideNow();
  resolveIdentity(uniqueCandidate());
}

// A floor that localised the scans must also be the only candidate they fit: the
// relocaliser's uniqueness test (every pose elsewhere below ambiguity_ratio times the
// estimate's score) with the other candidate floors as "elsewhere". A small floor is often
// a fit inside a bigger one, and floors are often alike around their lifts.
int FloorSessions::uniqueCandidate() {
  auto& candidates = identify_->relocalizers;
  int winner = -1;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const auto& [floor, relocalizer] = candidates[i];
    if (relocalizer->status() != RelocalizationStatus::kLocalized) continue;
    const RelocalizationResult& r = relocalizer->result();
    const std::vector<Eigen::Vector2d> points = relocalizer->recentPoints();
    std::string other_fit;
    for (const auto& [other, other_relocalizer] : candidates) {
      if (other == floor || !other_fit.empty()) continue;
      const double fit = other_relocalizer->bestFitAnywhere(points);
      if (fit >= relocalizer->options().ambiguity_ratio * r.own)
        other_fit = str("floor ", other, " fits them as well (", fit, " against ", r.own, ")");
    }
    common::logInfo(str("floor_sessions[", robot_, "]: floor ", floor,
                        " localises the arriving scans (score ", r.score, ")",
                        other_fit.empty() ? "" : "; but ", other_fit));
    if (other_fit.empty() &&
        (winner < 0 || candidates[static_cast<std::size_t>(winner)].second->result().own < r.own))
      winner = static_cast<int>(i);
  }
  return winner;
}

ScanResult FloorSessions::resolveIdentity(int winner) {
  const std::unique_ptr<Identification> id = std::move(identify_);
  const floor::FloorEvent& e = id->event;
  auto& candidates = id->relocalizers;
  int floor_id = winner >= 0 ? candidates[static_cast<std::size_t>(winner)].first : e.floor_id;
  // No map decides: a floor never seen when the height allows one and no candidate's map
  // fits the latest scans anywhere (the relocaliser's min_score); else the height's choice.
  if (winner < 0 && e.new_floor_id >= 0) {
    std::vector<Eigen::Vector2d> points;
    for (auto& [floor, relocalizer] : candidates)
      if (points.empty()) points = relocalizer->recentPoints();
    bool fits = false;
    for (auto& [floor, relocalizer] : candidates)
      fits = fits || points.empty() ||
             relocalizer->bestFitAnywhere(points) >= relocalizer->options().min_score;
    if (!fits) floor_id = e.new_floor_id;
  }
  identities_.push_back({e.stamp, floor_id, winner >= 0});
  if (winner >= 0) ++stats_.identified_by_map;
  common::logInfo(str(
      "floor_sessions[", robot_, "]: the ride that ended at ", e.stamp, " reached floor ", floor_id,
      winner >= 0 ? " (its map holds the arriving scans)" : " (no candidate's map decides)"));
  if (floor_id != id->left) floors_.at(id->left)->finish();
  current_floor_ = floor_id;
  ScanResult r;
  if (winner >= 0) {
    relocalizer_ = std::move(candidates[static_cast<std::size_t>(winner)].second);
    r.node_id = resumeRelocalized();
    r.status = ScanStatus::kNode;
    r.pose = current().currentPose();
    return r;
  }
  const auto it = floors_.find(floor_id);
  if (it != floors_.end() && !it->second->floorGraph().nodes.empty()) {
    openNewGraphOfCurrentFloor("not localised in its map");
  } else if (it == floors_.end()) {
    const double height = floor_id == e.new_floor_id ? e.new_floor_height : e.floor_height;
    common::logInfo(
        str("floor_sessions[", robot_, "]: new floor ", floor_id, " at ", height, " m"));
    floors_[floor_id] =
        std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, floor_id, height);
  }
  for (const auto& held : id->buffer) r = current().addScan(held.scan, held.odometry);
  return r;
}

std::vector<floor::FloorIdentity> FloorSessions::takeIdentities() {
  std::vector<floor::FloorIdentity> out;
  out.swap(identities_);
  return out;
}

}  // namespace storey::mapping
