// FloorSlam back on a known floor: resuming its graph where the relocaliser placed the robot.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "storey/common/log.h"
#include "storey/mapping/floor_slam.h"
#include "storey/mapping/floor_slam_internal.h"

namespace storey::mapping {

using common::str;
using geometry::Pose2;
using namespace detail;

int FloorSlam::resumeLocalized(const std::vector<GlobalRelocalizer::Buffered>& scans,
                               const Pose2& pose, const Eigen::Matrix3d& covariance) {
  Impl& s = *impl_;
  if (scans.empty()) throw std::invalid_argument("resumeLocalized: no scans");
  if (floor_graph_.nodes.empty()) throw std::logic_error("resumeLocalized: the floor has no map");
  // Which scans become nodes: the node-creation rule along the buffered odometry; the
  // last (the localised one) always.
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!keep.empty()) {
      const Pose2 step = scans[keep.back()].odometry.between(scans[i].odometry);
      if (step.translation().norm() < options_.node.min_translation &&
          std::abs(step.theta()) < options_.node.min_rotation)
        continue;
    }
    keep.push_back(i);
  }
  if (keep.back() != scans.size() - 1) keep.back() = scans.size() - 1;
  // Walk back from the localised scan: each earlier scan is predicted by odometry from
  // the one after it and matched in the floor's map as it was; a match ties that node
  // to its nearest old node too. A scan the old map does not show (the stairwell the
  // robot came down) is tracked instead against the chain's later scans, as tracking
  // does forwards. Either way odometry's heading drift over the buffered scans (tens of
  // them, with the landings' turns) does not skew the map.
  const std::size_t old_count = floor_graph_.nodes.size();
  const MatchTarget target =
      buildTarget(floor_graph_, 0, old_count, options_.local_map, kWideSearchLevels, s.matcher);
  std::vector<Pose2> poses(keep.size());
  std::vector<Eigen::Matrix3d> covariances(keep.size(), Eigen::Matrix3d::Zero());
  enum class Placed { kOdometry, kTied, kTracked };
  std::vector<Placed> placed(keep.size(), Placed::kOdometry);
  poses.back() = pose;
  covariances.back() = covariance;
  placed.back() = Placed::kTied;
  floor::FloorGraph chain;  // the scans placed so far, from the localised one backwards
  auto addToChain = [&](std::size_t j) {
    floor::FloorNode node;
    node.pose = poses[j];
    node.scan = scans[keep[j]].scan;
    chain.nodes.push_back(std::move(node));
  };
  addToChain(keep.size() - 1);
  for (std::size_t j = keep.size() - 1; j-- > 0;) {
    const Pose2 prediction =
        poses[j + 1] * scans[keep[j + 1]].odometry.between(scans[keep[j]].odometry);
    const std::vector<Eigen::Vector2d> points = filterPoints(
        scans[keep[j]].scan.pointsInRobotFrame(), options_.matcher.point_filter_distance);
    const MatchResult match = s.matcher.match(target, points, prediction);
    if (match.success && match.score >= options_.loop_closure.min_score) {
      placed[j] = Placed::kTied;
      poses[j] = match.pose;
      covariances[j] = match.covariance;
    } else {
      const MatchResult tracked = s.matcher.match(
          buildLocalTarget(chain, options_.local_map, s.matcher), points, prediction);
      placed[j] = tracked.success ? Placed::kTracked : Placed::kOdometry;
      poses[j] = tracked.success ? tracked.pose : prediction;
      if (tracked.success) covariances[j] = tracked.covariance;
    }
    addToChain(j);
  }
  std::vector<int> anchors(keep.size(), -1);
  for (std::size_t j = 0; j < keep.size(); ++j)
    if (placed[j] == Placed::kTied)
      anchors[j] = floor_graph_.nearestNodeIndex(poses[j].translation());
  std::vector<int> ids(keep.size(), -1);
  for (std::size_t j = 0; j < keep.size(); ++j) {
    const Pose2& p = poses[j];
    appendNode(scans[keep[j]].scan, scans[keep[j]].odometry, p, /*starts_run=*/true);
    ids[j] = floor_graph_.nodes.back().id;
    if (j > 0) {
      const Pose2 motion = scans[keep[j - 1]].odometry.between(scans[keep[j]].odometry);
      appendEdge(ids[j - 1], ids[j], motion, safeInformation(s.tracker.stepCovariance(motion)),
                 floor::EdgeKind::kOdometry);
    }
    if (placed[j] == Placed::kTied) {
      const floor::FloorNode& anchor = floor_graph_.nodes[anchors[j]];
      appendEdge(anchor.id, ids[j], anchor.pose.between(p),
                 safeInformation(rotateCovariance(covariances[j], anchor.pose.theta())),
                 floor::EdgeKind::kScanMatch);
    }
  }
  // Tracked scans: matched against the later ones, so their edge comes from the next node.
  for (std::size_t j = 0; j + 1 < keep.size(); ++j)
    if (placed[j] == Placed::kTracked)
      appendEdge(ids[j + 1], ids[j], poses[j + 1].between(poses[j]),
                 safeInformation(rotateCovariance(covariances[j], poses[j + 1].theta())),
                 floor::EdgeKind::kScanMatch);
  const int previous = ids.back();
  covariance_ = covariance;
  relocalize_ = false;
  ++stats_.relocalizations;
  s.have_last = true;
  s.last_stamp = scans.back().scan.stamp;
  s.tracker.start(floor_graph_.nodes.back().pose, scans.back().odometry, covariance);
  s.last_node_odometry_agrees = true;
  s.beam_count = scans.back().scan.size();
  s.local_dirty = true;
  s.nodes_since_attempt = 0;
  return previous;
}

bool FloorSlam::continuesHere(const sensor::LaserScan& scan, const Pose2& odometry) {
  Impl& s = *impl_;
  if (floor_graph_.nodes.empty() || relocalize_ || !s.tracker.started()) return false;
  if (s.local_dirty) {
    s.local_target = buildLocalTarget(floor_graph_, options_.local_map, s.matcher);
    s.local_dirty = false;
    s.nodes_since_rebuild = 0;
  }
  const std::vector<Eigen::Vector2d> points =
      filterPoints(scan.pointsInRobotFrame(), options_.matcher.point_filter_distance);
  if (points.size() < static_cast<std::size_t>(options_.matcher.min_points)) return false;
  const TrackPrediction p = s.tracker.predict(odometry);
  const MatchResult m =
      s.matcher.match(s.local_target, points, p.pose, p.linear_window, p.angular_window);
  return m.success && m.score >= options_.loop_closure.min_score;
}

ScanResult FloorSlam::relocalizeWith(const sensor::LaserScan& scan, const Pose2& odometry,
                                     const std::vector<Eigen::Vector2d>& points) {
  Impl& s = *impl_;
  const RelocalizationOptions& o = options_.relocalization;
  ScanResult result;
  if (!s.reloc_have_odometry) {
    s.reloc_have_odometry = true;
    s.reloc_odometry = odometry;
  }
  const Pose2 guess = s.reloc_guess * s.reloc_odometry.between(odometry);
  if (!s.floor_target_valid) {
    s.floor_target = buildTarget(floor_graph_, 0, floor_graph_.nodes.size(), options_.local_map,
                                 kWideSearchLevels, s.reloc_matcher);
    s.floor_target_valid = true;
  }
  const MatchResult match =
      s.reloc_matcher.match(s.floor_target, points, guess, o.linear_window, o.angular_window);
  ++s.reloc_attempts;
  const bool found = match.success && match.score >= o.min_score;
  if (!found && s.reloc_attempts < o.max_attempts) {
    result.status = ScanStatus::kRejected;
    result.reason = str("relocalising (attempt ", s.reloc_attempts,
                        "): ", match.success ? "score too low" : match.problem);
    result.pose = guess;
    ++stats_.rejected;
    return result;
  }
  Pose2 pose = guess;
  Eigen::Matrix3d cov;
  if (found) {
    pose = match.pose;
    cov = match.covariance;
    ++stats_.relocalizations;
    result.relocalized = true;
  } else {
    // Nothing matched: resume on the guess with a weak tie so the graph stays connected.
    ++stats_.relocalization_failures;
    common::logWarn(str("floor_slam: could not localise on floor ", floor_graph_.floor_id,
                        " after ", s.reloc_attempts,
                        " scans; resuming at the expected arrival pose"));
    cov = Eigen::Vector3d(1.0, 1.0, 0.25).asDiagonal();
  }
  const int nearest = floor_graph_.nearestNodeIndex(pose.translation());
  const floor::FloorNode anchor = floor_graph_.nodes[nearest];
  appendNode(scan, odometry, pose, /*starts_run=*/true);
  const Eigen::Matrix3d info = safeInformation(rotateCovariance(cov, anchor.pose.theta()));
  appendEdge(anchor.id, floor_graph_.nodes.back().id, anchor.pose.between(pose), info,
             floor::EdgeKind::kLoopClosure);
  covariance_ = cov;
  relocalize_ = false;
  s.tracker.start(pose, odometry, cov);
  s.last_node_odometry_agrees = true;
  result.status = ScanStatus::kNode;
  result.node_id = floor_graph_.nodes.back().id;
  result.pose = pose;
  return result;
}

}  // namespace storey::mapping
