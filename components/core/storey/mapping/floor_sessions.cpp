#include "storey/mapping/floor_sessions.h"

#include <cmath>

#include "storey/common/log.h"

namespace storey::mapping {

using common::str;

namespace {
constexpr double kHeldTransitSeconds = 60.0;
}  // namespace

FloorSessions::FloorSessions(FloorSlamOptions options, std::string robot, int initial_floor,
                             double initial_height, int first_graph_id)
    : options_(std::move(options)), robot_(std::move(robot)), current_floor_(initial_floor),
      next_graph_id_(first_graph_id) {
  floors_[initial_floor] =
      std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, initial_floor, initial_height);
}

FloorSessions::~FloorSessions() = default;

ScanResult FloorSessions::addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
  ScanResult r;
  r.pose = current().currentPose();
  if (in_transit_) {
    transit_scans_.push_back({scan, odometry});
    // Only scans after the ride's end are wanted, and the detector decides an end 3-15 s
    // after it (settle_time, new_floor_settle_time): a minute is plenty.
    while (transit_scans_.front().scan.stamp < scan.stamp - kHeldTransitSeconds)
      transit_scans_.pop_front();
    r.status = ScanStatus::kSkipped;
    r.reason = "in transit";
    return r;
  }
  if (identify_) return addIdentifyingScan(scan, odometry);
  if (!relocalizer_) return current().addScan(scan, odometry);

  const auto& buffer = relocalizer_->buffer();
  if (rejectedForBuffer(scan, odometry, buffer.empty() ? -1e300 : buffer.back().scan.stamp, r))
    return r;
  const RelocalizationStatus status = relocalizer_->add(scan, odometry);
  last_relocalization_ = relocalizer_->result();
  if (status == RelocalizationStatus::kSearching) {
    r.status = ScanStatus::kSkipped;
    r.reason = "relocalising";
    return r;
  }
  if (status == RelocalizationStatus::kFailed) {
    openNewGraphOfCurrentFloor(str("no unique global localisation in ", relocalizer_->buffer().size(),
                                   " scans (", last_relocalization_.last_problem, ")"));
    r.pose = current().currentPose();
    r.status = ScanStatus::kNode;
    return r;
  }
  const RelocalizationResult result = relocalizer_->result();
  const int node = resumeRelocalized();
  r.status = ScanStatus::kNode;
  r.node_id = node;
  r.pose = result.pose;
  r.matched = true;
  r.relocalized = true;
  return r;
}

bool FloorSessions::rejectedForBuffer(const sensor::LaserScan& scan,
                                      const geometry::Pose2& odometry, double last_stamp,
                                      ScanResult& r) const {
  std::string why = scan.validate();
  if (why.empty() && !std::isfinite(scan.stamp)) why = "non-finite stamp";
  if (why.empty() && !odometry.isFinite()) why = "non-finite odometry pose";
  if (why.empty() && scan.stamp < last_stamp)
    why = str("time went backwards (", scan.stamp, " < ", last_stamp, ")");
  if (why.empty() &&
      filterPoints(scan.pointsInRobotFrame(), options_.matcher.point_filter_distance).size() <
          static_cast<std::size_t>(options_.matcher.min_points))
    why = "too few valid returns";
  if (why.empty()) return false;
  common::logWarn(str("floor_sessions[", robot_, "]: scan at ", scan.stamp, " rejected: ", why));
  r.status = ScanStatus::kRejected;
  r.reason = why;
  return true;
}

int FloorSessions::resumeRelocalized() {
  const RelocalizationResult& result = relocalizer_->result();
  last_relocalization_ = result;
  const int node = current().resumeLocalized(relocalizer_->buffer(), result.pose, result.covariance);
  ++stats_.global_relocalizations;
  common::logInfo(str("floor_sessions[", robot_, "]: relocalised on floor ", current_floor_, " after ",
                      relocalizer_->buffer().size(), " scans at (", result.pose.x(), ", ", result.pose.y(), ", ",
                      result.pose.theta(), "), score ", result.score, ", best elsewhere ", result.best_other,
                      " vs ", result.own));
  relocalizer_.reset();
  return node;
}

void FloorSessions::openNewGraphOfCurrentFloor(const std::string& why) {
  ++stats_.fallbacks;
  common::logInfo(str("floor_sessions[", robot_, "]: back on floor ", current_floor_, ": a new floor graph (",
                      why, "); the matcher aligns it"));
  auto& slot = floors_.at(current_floor_);
  const double height = slot->floorGraph().floor_height;
  retired_.push_back(std::move(slot));
  slot = std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, current_floor_, height);
  if (relocalizer_) {
    const auto reloc = std::move(relocalizer_);
    for (const auto& b : reloc->buffer()) slot->addScan(b.scan, b.odometry);
  }
}

void FloorSessions::beginTransit() {
  if (in_transit_) return;
  decideIdentity();
  transit_scans_.clear();
  // Leaving before the floor was recognised: keep what was seen, in a graph of its own.
  if (relocalizer_) openNewGraphOfCurrentFloor("left again before localising");
  in_transit_ = true;
  exit_pose_[current_floor_] = current().currentPose();
}

void FloorSessions::endTransit(int floor_id, double floor_height, double end_stamp) {
  std::deque<HeldScan> arrival;
  arrival.swap(transit_scans_);
  while (!arrival.empty() && !(arrival.front().scan.stamp > end_stamp)) arrival.pop_front();
  switchFloorAfterTransit(floor_id, floor_height);
  // Only a graph that starts here takes them. Localising in a known map, the scans in the
  // cabin are a box with a door like every shaft of the floor: on corridors3 they tied
  // the return to the stairwell's landing, 40 m off, as unique.
  if (arrival.empty() || relocalizer_ || !current().floorGraph().nodes.empty()) return;
  common::logDebug(str("floor_sessions[", robot_, "]: ", arrival.size(), " scans after the ride's end at ",
                       end_stamp, " start floor ", current_floor_, "'s graph"));
  for (const auto& held : arrival) addScan(held.scan, held.odometry);
}

void FloorSessions::switchFloorAfterTransit(int floor_id, double floor_height) {
  if (!in_transit_) exit_pose_[current_floor_] = current().currentPose();
  in_transit_ = false;
  if (floor_id == current_floor_) {
    // Back where it started (an aborted ride): continue, but re-check the pose first.
    if (!current().floorGraph().nodes.empty()) current().resumeAt(exit_pose_[floor_id]);
    return;
  }
  current().finish();
  current_floor_ = floor_id;
  auto it = floors_.find(floor_id);
  if (it == floors_.end()) {
    common::logInfo(str("floor_sessions[", robot_, "]: new floor ", floor_id, " at ", floor_height, " m"));
    floors_[floor_id] = std::make_unique<FloorSlam>(options_, robot_, next_graph_id_++, floor_id, floor_height);
    return;
  }
  if (it->second->floorGraph().nodes.empty()) return;  // nothing to localise in
  if (options_.relocalization.known_floor == "new_graph") {
    openNewGraphOfCurrentFloor("relocalization.known_floor: new_graph");
    return;
  }
  common::logInfo(str("floor_sessions[", robot_, "]: back on floor ", floor_id, "; localising globally"));
  ++arrivals_;
  relocalizer_ = relocalizerFor(floor_id);
}

std::unique_ptr<GlobalRelocalizer> FloorSessions::relocalizerFor(int floor_id, int restart) const {
  GlobalRelocalizationOptions g = options_.relocalization.global;
  g.seed = g.seed * 0x9E3779B97F4A7C15ULL +
           static_cast<std::uint64_t>(arrivals_) * 0xC2B2AE3D27D4EB4FULL +
           static_cast<std::uint64_t>(floor_id) +
           static_cast<std::uint64_t>(restart) * 0x9E3779B97F4A7C15ULL;
  return std::make_unique<GlobalRelocalizer>(
      floors_.at(floor_id)->floorGraph(), g, options_.loop_closure.matcher,
      options_.local_map.field, options_.local_map.max_insert_range);
}

void FloorSessions::flush() {
  decideIdentity();
  if (relocalizer_ && relocalizer_->decideNow()) resumeRelocalized();
  if (relocalizer_) openNewGraphOfCurrentFloor("the input ended before localising");
  if (floors_.count(current_floor_)) current().finish();
}

}  // namespace storey::mapping
