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
  current().finish();
  identify_ = std::make_unique<Identification>();
  identify_->event = event;
  ++arrivals_;
  if (options_.relocalization.known_floor != "new_graph") {
    for (const int floor : event.candidate_floors) {
      const auto it = floors_.find(floor);
      if (it == floors_.end() || it->second->floorGraph().nodes.empty())
        continue;  // no map of it here
      identify_->relocalizers.emplace_back(
          floor, std::make_unique<GlobalRelocalizer>(
                     it->second->floorGraph(), arrivalOptions(floor), options_.loop_closure.matcher,
                     options_.local_map.field, options_.local_map.max_insert_range));
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
  if (identify_->relocalizers.empty()) resolveIdentity();
}

ScanResult FloorSessions::addIdentifyingScan(const sensor::LaserScan& scan,
                                             const geometry::Pose2& odometry) {
  ScanResult r;
  r.pose = current().currentPose();
  auto& buffer = identify_->buffer;
  const std::string why =
      invalidForBuffer(scan, odometry, buffer.empty() ? -1e300 : buffer.back().scan.stamp);
  if (!why.empty()) {
    common::logWarn(str("floor_sessions[", robot_, "]: scan at ", scan.stamp, " rejected: ", why));
    r.status = ScanStatus::kRejected;
    r.reason = why;
    return r;
  }
  buffer.push_back({scan, odometry});
  bool localized = false, searching = false;
  for (auto& [floor, relocalizer] : identify_->relocalizers) {
    if (relocalizer->status() == RelocalizationStatus::kSearching) relocalizer->add(scan, odometry);
    localized = localized || relocalizer->status() == RelocalizationStatus::kLocalized;
    searching = searching || relocalizer->status() == RelocalizationStatus::kSearching;
  }
  if (!localized && searching) {
    r.status = ScanStatus::kSkipped;
    r.reason = "identifying the floor";
    return r;
  }
  // One floor holds the scans, or none can: the others are checked with what they have.
  decideIdentity();
  r.status = ScanStatus::kNode;
  r.pose = current().currentPose();
  r.relocalized = localized;
  r.matched = localized;
  return r;
}

void FloorSessions::decideIdentity() {
  if (!identify_) return;
  for (auto& [floor, relocalizer] : identify_->relocalizers)
    if (relocalizer->status() == RelocalizationStatus::kSearching) relocalizer->decideNow();
  resolveIdentity();
}

ScanResult FloorSessions::resolveIdentity() {
  const std::unique_ptr<Identification> id = std::move(identify_);
  const floor::FloorEvent& e = id->event;
  auto& candidates = id->relocalizers;  // nearest in height first
  // A floor that localised the scans must also be the only candidate they fit: the
  // relocaliser's uniqueness test (every pose elsewhere below ambiguity_ratio times the
  // estimate's score) with the other candidate floors as "elsewhere". A small floor is
  // often a fit inside a bigger one.
  std::unique_ptr<GlobalRelocalizer>* found = nullptr;
  int floor_id = -1;
  for (auto& [floor, relocalizer] : candidates) {
    if (relocalizer->status() != RelocalizationStatus::kLocalized) continue;
    const RelocalizationResult& r = relocalizer->result();
    const std::vector<Eigen::Vector2d> points = relocalizer->recentPoints();
    std::string other_fit;
    for (auto& [other, other_relocalizer] : candidates) {
      if (other == floor) continue;
      const double fit = other_relocalizer->bestFitAnywhere(points);
      if (fit >= relocalizer->options().ambiguity_ratio * r.own)
        other_fit = str("floor ", other, " fits them as well (", fit, " against ", r.own, ")");
    }
    common::logInfo(str("floor_sessions[", robot_, "]: floor ", floor,
                        " localises the arriving scans (score ", r.score, ")",
                        other_fit.empty() ? "" : "; but ", other_fit));
    if (!other_fit.empty() || (found && (*found)->result().own >= r.own)) continue;
    found = &relocalizer;
    floor_id = floor;
  }
  // No map decides: a floor never seen when the height allows one and no candidate's map
  // fits the scans anywhere (the relocaliser's min_score); else the height's choice.
  if (!found) {
    floor_id = e.floor_id;
    if (e.new_floor_id >= 0) {
      std::vector<Eigen::Vector2d> points;
      for (auto& [floor, relocalizer] : candidates)
        if (points.empty()) points = relocalizer->recentPoints();
      bool fits = false;
      for (auto& [floor, relocalizer] : candidates)
        fits = fits || points.empty() ||
               relocalizer->bestFitAnywhere(points) >= relocalizer->options().min_score;
      if (!fits) floor_id = e.new_floor_id;
    }
  }
  identities_.push_back({e.stamp, floor_id, found != nullptr});
  if (found) ++stats_.identified_by_map;
  common::logInfo(str(
      "floor_sessions[", robot_, "]: the ride that ended at ", e.stamp, " reached floor ", floor_id,
      found ? " (its map holds the arriving scans)" : " (no candidate's map decides)"));
  current_floor_ = floor_id;
  ScanResult r;
  if (found) {
    relocalizer_ = std::move(*found);
    resumeRelocalized();
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
