#include "storey/mapping/floor_slam.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "storey/common/log.h"
#include "storey/mapping/floor_slam_internal.h"

namespace storey::mapping {

using common::str;
using geometry::Pose2;
using namespace detail;

namespace detail {

graph::EdgeKind toGraphKind(floor::EdgeKind kind) {
  switch (kind) {
    case floor::EdgeKind::kOdometry: return graph::EdgeKind::kOdometry;
    case floor::EdgeKind::kScanMatch: return graph::EdgeKind::kScanMatch;
    case floor::EdgeKind::kLoopClosure: return graph::EdgeKind::kLoopClosure;
  }
  return graph::EdgeKind::kOdometry;
}

Eigen::Matrix3d safeInformation(const Eigen::Matrix3d& covariance) {
  Eigen::Matrix3d info = covariance.inverse();
  info = 0.5 * (info + info.transpose());
  if (!graph::informationProblem(info).empty()) {
    // Fall back to the diagonal: never hand the optimiser an indefinite matrix.
    info = Eigen::Matrix3d::Zero();
    for (int i = 0; i < 3; ++i) info(i, i) = 1.0 / std::max(covariance(i, i), 1e-12);
  }
  return info;
}

graph::OptimizerOptions withoutRobustKernels(graph::OptimizerOptions options) {
  for (auto& kernel : options.robust) kernel = graph::RobustKernel{};
  return options;
}

// Standard deviation along the least certain horizontal axis of a pose covariance (m).
double largestTranslationStddev(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance.topLeftCorner<2, 2>());
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

// The matched step with the odometry's position along directions the match knows little
// of. Degeneracy: in a bare corridor the match knows less along the axis than odometry does,
// and its correlative result there lags at the local map's frontier (the ring of
// FloorSlam.LoopClosureCorrectsDrift stood still for 15 m). Elsewhere, and in heading, the
// step stays the match's (fusing those too followed odometry's noise: infinite-corridor
// nearby 0.45° -> 0.62°, the office test's worst 0.17 m).
namespace {

// The horizontal unit directions (the match information's eigenvectors) along which the
// match's information is below `ratio` times the odometry's.
std::vector<Eigen::Vector2d> degenerateDirections(const Eigen::Matrix3d& match_information,
                                                  const Eigen::Matrix3d& odometry_information,
                                                  double ratio) {
  const Eigen::Matrix2d odometry_info = odometry_information.topLeftCorner<2, 2>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> directions(
      match_information.topLeftCorner<2, 2>());
  std::vector<Eigen::Vector2d> degenerate;
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d v = directions.eigenvectors().col(k);
    if (directions.eigenvalues()(k) < ratio * v.dot(odometry_info * v)) degenerate.push_back(v);
  }
  return degenerate;
}

}  // namespace

Pose2 withOdometryWhereDegenerate(const Pose2& matched, const Eigen::Matrix3d& match_information,
                                  const Pose2& odometry, const Eigen::Matrix3d& odometry_information, double ratio) {
  const Eigen::Matrix2d match_info = match_information.topLeftCorner<2, 2>();
  const Eigen::Matrix2d odometry_info = odometry_information.topLeftCorner<2, 2>();
  const Eigen::Vector2d fused = (odometry_info + match_info)
                                    .ldlt()
                                    .solve(odometry_info * odometry.translation() + match_info * matched.translation());
  Eigen::Vector2d position = matched.translation();
  for (const Eigen::Vector2d& v :
       degenerateDirections(match_information, odometry_information, ratio))
    position += v * v.dot(fused - position);
  return Pose2(position.x(), position.y(), matched.theta());
}

Eigen::Matrix3d odometryWhereDegenerate(const Eigen::Matrix3d& match_information,
                                        const Eigen::Matrix3d& odometry_information, double ratio) {
  const Eigen::Matrix2d odometry_info = odometry_information.topLeftCorner<2, 2>();
  Eigen::Matrix3d added = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector2d& v :
       degenerateDirections(match_information, odometry_information, ratio))
    added.topLeftCorner<2, 2>() += v.dot(odometry_info * v) * v * v.transpose();
  return added;
}

// Whether a match with this covariance (map frame) claims to know its place along `offset`
// to better than the offset's length (sigma_factor σ along it), unlike a match along a
// bare corridor's axis, whose σ there spans such an offset.
bool pinsAlong(const Eigen::Matrix3d& covariance, const Eigen::Vector2d& offset, double sigma_factor) {
  const Eigen::Vector2d direction = offset.normalized();
  const double sigma = std::sqrt(std::max(0.0, direction.dot(covariance.topLeftCorner<2, 2>() * direction)));
  return sigma_factor * sigma < offset.norm();
}

}  // namespace detail

const char* scanStatusName(ScanStatus status) {
  switch (status) {
    case ScanStatus::kNode: return "node";
    case ScanStatus::kSkipped: return "skipped";
    case ScanStatus::kRejected: return "rejected";
  }
  return "unknown";
}

const char* loopOutcomeName(LoopOutcome outcome) {
  switch (outcome) {
    case LoopOutcome::kNoMatch: return "no_match";
    case LoopOutcome::kAccepted: return "accepted";
    case LoopOutcome::kInconsistent: return "inconsistent";
    case LoopOutcome::kUnconfirmed: return "unconfirmed";
    case LoopOutcome::kAmbiguous: return "ambiguous";
  }
  return "unknown";
}

Eigen::Matrix3d rotateCovariance(const Eigen::Matrix3d& covariance, double theta) {
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  const double c = std::cos(theta), s = std::sin(theta);
  j(0, 0) = c;
  j(0, 1) = s;
  j(1, 0) = -s;
  j(1, 1) = c;
  return j * covariance * j.transpose();
}

FloorSlam::FloorSlam(FloorSlamOptions options, std::string robot, int graph_id, int floor_id,
                     double floor_height)
    : impl_(std::make_unique<Impl>(options)), options_(std::move(options)) {
  floor_graph_.robot = std::move(robot);
  floor_graph_.graph_id = graph_id;
  floor_graph_.floor_id = floor_id;
  floor_graph_.floor_height = floor_height;
}
FloorSlam::~FloorSlam() = default;
FloorSlam::FloorSlam(FloorSlam&&) noexcept = default;
FloorSlam& FloorSlam::operator=(FloorSlam&&) noexcept = default;

namespace detail {

// The map of nodes [first, last) for `matcher`: their scans in an occupancy grid
// (likelihood field and pyramid for the search) and, where the matcher refines on points
// (and point_cell_size is not 0), as points; a matcher that refines on the field would
// never look at them.
MatchTarget buildTarget(const floor::FloorGraph& graph, const std::vector<std::size_t>& indices,
                        const LocalMapOptions& o, int pyramid_levels, const ScanMatcher& matcher,
                        grid::OccupancyGrid* grid_out) {
  grid::OccupancyGridOptions go;
  go.resolution = o.resolution;
  go.max_insert_range = o.max_insert_range;
  // The grid reaches as far beyond the returns as the search can look.
  go.growth_margin = MatchTarget::gridMargin(o.field, o.resolution, pyramid_levels);
  grid::OccupancyGrid map(go);
  std::vector<grid::OccupancyGrid::PosedScan> scans;
  for (std::size_t i : indices) scans.push_back({&graph.nodes[i].scan, graph.nodes[i].pose});
  map.insertScans(scans);
  MatchTarget target(map, o.field, pyramid_levels);
  if (grid_out) *grid_out = std::move(map);
  if (matcher.options().point_refinement && o.point_cell_size > 0.0)
    target.setPoints(grid::PointMap(floor::floorPoints(graph, indices, o.max_insert_range), o.point_cell_size,
                                    o.point_normal_radius));
  return target;
}

// Nodes [first, last).
MatchTarget buildTarget(const floor::FloorGraph& graph, std::size_t first, std::size_t last,
                        const LocalMapOptions& o, int pyramid_levels, const ScanMatcher& matcher,
                        grid::OccupancyGrid* grid_out) {
  std::vector<std::size_t> indices;
  for (std::size_t i = first; i < last && i < graph.nodes.size(); ++i) indices.push_back(i);
  return buildTarget(graph, indices, o, pyramid_levels, matcher, grid_out);
}

// The robot-frame points that land, at `pose`, where `grid` has looked: on a cell it observed,
// or just in front of one (seen free from the sensor's side), so a point a little beyond a
// wall the map saw stays and a point on a wall it never saw goes.
std::vector<Eigen::Vector2d> pointsWhereObserved(const std::vector<Eigen::Vector2d>& points,
                                                 const Pose2& pose,
                                                 const grid::OccupancyGrid& grid) {
  const double back = 2.0 * grid.frame().resolution;
  auto observed = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2i c = grid.frame().cellOf(pose.transformPoint(p));
    return grid.logOddsAt(c.x(), c.y()) != 0.0f;
  };
  std::vector<Eigen::Vector2d> kept;
  for (const auto& p : points) {
    const double range = p.norm();
    if (observed(p) || (range > back && observed(p * (1.0 - back / range)))) kept.push_back(p);
  }
  return kept;
}

// The tracking map: the graph's last `max_nodes` nodes.
MatchTarget buildLocalTarget(const floor::FloorGraph& graph, const LocalMapOptions& o, const ScanMatcher& matcher) {
  const std::size_t n = graph.nodes.size();
  const std::size_t first = n > static_cast<std::size_t>(o.max_nodes) ? n - o.max_nodes : 0;
  return buildTarget(graph, first, n, o, o.pyramid_levels, matcher);
}

}  // namespace detail

void FloorSlam::resumeAt(const Pose2& guess) {
  if (floor_graph_.nodes.empty()) return;  // nothing to localise in: start fresh
  relocalize_ = true;
  impl_->reloc_guess = guess;
  impl_->reloc_have_odometry = false;
  impl_->reloc_attempts = 0;
  impl_->floor_target_valid = false;
}

GraphUpdate FloorSlam::takeUpdate() {
  GraphUpdate update;
  for (std::size_t i = impl_->update_nodes_from; i < floor_graph_.nodes.size(); ++i)
    update.new_nodes.push_back(floor_graph_.nodes[i]);
  impl_->update_nodes_from = floor_graph_.nodes.size();
  update.new_edges.swap(impl_->update_edges);
  update.poses_changed = impl_->poses_changed;
  impl_->poses_changed = false;
  return update;
}

void FloorSlam::optimize() {
  if (pose_graph_.numNodes() < 2) return;
  const Pose2 before = floor_graph_.nodes.back().pose;
  try {
    impl_->optimizer.optimize(pose_graph_);
    ++stats_.optimizations;
  } catch (const std::exception& e) {
    common::logWarn(str("floor_slam: optimisation failed: ", e.what()));
    return;
  }
  for (auto& node : floor_graph_.nodes) node.pose = pose_graph_.node(node.id).pose;
  const Pose2 correction = floor_graph_.nodes.back().pose * before.inverse();
  impl_->tracker.correct(correction);
  last_pose_ = correction * last_pose_;
  impl_->local_dirty = true;
  impl_->floor_target_valid = false;
  impl_->poses_changed = true;
  try {
    const graph::NodeId id = floor_graph_.nodes.back().id;
    const auto marginals = impl_->optimizer.marginalCovariances(pose_graph_, {id});
    const Eigen::Matrix3d cov = marginals.at(id);
    if (cov.allFinite()) covariance_ = cov;
  } catch (const std::exception& e) {
    common::logDebug(str("floor_slam: no marginal covariance: ", e.what()));
  }
}

ScanResult FloorSlam::addScan(const sensor::LaserScan& scan, const Pose2& odometry) {
  Impl& s = *impl_;
  ScanResult result;
  ++stats_.scans;
  auto reject = [&](const std::string& why) {
    ++stats_.rejected;
    result.status = ScanStatus::kRejected;
    result.reason = why;
    result.pose = last_pose_;
    common::logWarn(str("floor_slam[", floor_graph_.robot, " floor ", floor_graph_.floor_id, "]: scan at ",
                        scan.stamp, " rejected: ", why));
    return result;
  };
  if (const std::string why = scan.validate(); !why.empty()) return reject(why);
  if (!std::isfinite(scan.stamp)) return reject("non-finite stamp");
  if (!odometry.isFinite()) return reject("non-finite odometry pose");
  if (s.have_last && scan.stamp < s.last_stamp)
    return reject(str("time went backwards (", scan.stamp, " < ", s.last_stamp, ")"));
  const std::vector<Eigen::Vector2d> points =
      filterPoints(scan.pointsInRobotFrame(), options_.matcher.point_filter_distance);
  if (s.beam_count != 0 && scan.size() != s.beam_count)
    common::logWarn(str("floor_slam: scan at ", scan.stamp, " has ", scan.size(), " beams (was ",
                        s.beam_count, "); matching its points as they are"));
  s.beam_count = scan.size();
  s.have_last = true;
  s.last_stamp = scan.stamp;

  // First scan of the floor: the origin (the first with something to map).
  if (floor_graph_.nodes.empty()) {
    if (points.empty()) return reject("no returns in range to start the floor's map with");
    appendNode(scan, odometry, Pose2(), /*starts_run=*/true);
    s.tracker.start(Pose2(), odometry, Eigen::Matrix3d::Zero());
    s.last_node_odometry_agrees = true;
    covariance_ = Eigen::Matrix3d::Zero();
    result.status = ScanStatus::kNode;
    result.node_id = floor_graph_.nodes.back().id;
    return result;
  }
  if (relocalize_) return relocalizeWith(scan, odometry, points);
  if (!s.tracker.started()) s.tracker.start(last_pose_, odometry, covariance_);
  if (points.empty()) {
    // Nothing in range (an open hall for a short-range laser): placed by odometry, and the
    // next scan searched wider; not a node, having nothing to map.
    const TrackPrediction prediction = s.tracker.predict(odometry);
    s.tracker.unmatched(odometry, prediction);
    ++stats_.skipped;
    last_pose_ = prediction.pose;
    result.status = ScanStatus::kSkipped;
    result.reason = "no returns in range";
    result.pose = prediction.pose;
    return result;
  }

  // Every scan is tracked against the recent nodes' map, in the window the odometry's
  // uncertainty since the last tracked scan asks for; while the odometry disagrees with the
  // scans, also where its motion since it last agreed puts the scan (stale odometry that
  // caught up).
  if (s.local_dirty) {
    s.local_target = buildLocalTarget(floor_graph_, options_.local_map, s.matcher);
    s.local_dirty = false;
    s.nodes_since_rebuild = 0;
  }
  TrackPrediction prediction = s.tracker.predict(odometry);
  auto search = [&](const MatchTarget& target, const TrackPrediction& p) {
    return s.matcher.match(target, points, p.pose, p.linear_window, p.angular_window);
  };
  MatchResult match = search(s.local_target, prediction);
  if (const auto from_anchor = s.tracker.predictFromAnchor(odometry)) {
    const MatchResult caught_up = search(s.local_target, *from_anchor);
    if (caught_up.success &&
        (!match.success || caught_up.correlative_score > match.correlative_score)) {
      match = caught_up;
      prediction = *from_anchor;
      ++stats_.caught_up_matches;
      result.caught_up = true;
    }
  }
  const LocalMapOptions& lm = options_.local_map;
  if (!match.success && lm.retry_nodes > 0 && lm.retry_nodes < lm.max_nodes &&
      floor_graph_.nodes.size() > static_cast<std::size_t>(lm.retry_nodes)) {
    const std::size_t n = floor_graph_.nodes.size();
    const MatchResult retry =
        search(buildTarget(floor_graph_, n - lm.retry_nodes, n, lm, lm.pyramid_levels, s.matcher),
               prediction);
    if (retry.success) {
      ++stats_.retry_matches;
      match = retry;
    }
  }
  // Not where the odometry says: perhaps the odometry is wrong (it jumped, stalled or
  // slipped). The scan is searched around the last tracked pose in the largest window, and
  // a match there is used only if it is at least as sure of the pose as the tracking window
  // assumes odometry to be (3 σ within the smallest window): in a corridor's look-alike
  // places a match is as unsure as the window.
  if (!match.success) {
    TrackPrediction around_last;
    around_last.pose = s.tracker.pose();
    around_last.linear_window = options_.max_linear_window;
    around_last.angular_window = options_.max_angular_window;
    around_last.covariance = prediction.covariance;
    MatchResult wide = s.matcher.match(s.local_target, points, around_last.pose,
                                       around_last.linear_window, around_last.angular_window);
    const bool sure =
        wide.success &&
        3.0 * largestTranslationStddev(wide.covariance) <= options_.matcher.linear_window &&
        3.0 * std::sqrt(std::max(0.0, wide.covariance(2, 2))) <= options_.matcher.angular_window;
    if (sure) {
      ++stats_.wide_matches;
      result.wide = true;
      match = wide;
      prediction = around_last;
      common::logWarn(str("floor_slam: the scan at ", scan.stamp, " matched ",
                          s.tracker.predict(odometry).pose.between(wide.pose).translation().norm(),
                          " m from where ", "odometry put it; that odometry step is not trusted"));
    }
  }

  Pose2 pose = prediction.pose;
  bool odometry_agrees = true;
  if (match.success) {
    // Along a direction where the match knows less than the prediction (a bare corridor's
    // axis), the two fused by their information; elsewhere the match's.
    pose = options_.degenerate_ratio > 0.0 && !result.wide
               ? withOdometryWhereDegenerate(
                     match.pose, safeInformation(match.covariance), prediction.pose,
                     safeInformation(prediction.step_covariance), options_.degenerate_ratio)
               : match.pose;
    // A scan found around the last pose says the odometry failed (no noise to learn from).
    odometry_agrees = !result.wide && s.tracker.check(odometry, pose, match.covariance, prediction);
    if (!odometry_agrees) ++stats_.disagreeing_matches;
  }
  const floor::FloorNode& last = floor_graph_.nodes.back();
  const Pose2 motion = last.pose.between(pose);
  const bool moved = motion.translation().norm() >= options_.node.min_translation ||
                     std::abs(motion.theta()) >= options_.node.min_rotation;
  if (!match.success) {
    s.tracker.unmatched(odometry, prediction);
    common::logDebug(str("floor_slam: scan at ", scan.stamp, " not matched (", match.problem,
                         "); searching wider next"));
  } else if (!moved && odometry_agrees && s.tracker.odometryAgrees()) {
    // A short step the odometry agrees with: its pose is the prediction (over a few
    // centimetres odometry is more precise than a match), and tracking stays at the node.
    pose = prediction.pose;
  } else {
    // Relative to the map, the pose is known as the match knows it or, where the match knows
    // less (a corridor's axis), as the odometry's last step does: the map moved with the
    // estimate that built it, so what came before that step does not count.
    const Eigen::Matrix3d known =
        result.wide ? match.covariance
                    : Eigen::Matrix3d((safeInformation(match.covariance) +
                                       safeInformation(prediction.step_covariance))
                                          .inverse());
    s.tracker.moveTo(odometry, pose, known, odometry_agrees);
  }
  last_pose_ = pose;
  result.pose = pose;
  result.matched = match.success;
  result.score = match.success ? match.correlative_score : 0.0;
  result.odometry_agrees = odometry_agrees;
  if (!moved) {
    ++stats_.skipped;
    result.status = ScanStatus::kSkipped;
    return result;
  }
  if (match.success)
    ++stats_.matched;
  else
    ++stats_.match_failures;

  // A node: its odometry edge when the odometry agreed with the scans at both ends (a stall
  // or a slip between them would pull the graph its way), its scan-match edge when matched.
  const int from = last.id;
  const Pose2 last_pose = last.pose;
  const Pose2 odometry_step = last.odometry.between(odometry);
  const Eigen::Matrix3d odometry_covariance = s.tracker.stepCovariance(odometry_step);
  const bool odometry_edge = !match.success || (odometry_agrees && s.last_node_odometry_agrees);
  appendNode(scan, odometry, pose, /*starts_run=*/false);
  s.last_node_odometry_agrees = odometry_agrees;
  const int to = floor_graph_.nodes.back().id;
  if (odometry_edge)
    appendEdge(from, to, odometry_step, safeInformation(odometry_covariance),
               floor::EdgeKind::kOdometry);
  Eigen::Matrix3d step_covariance = odometry_covariance;
  if (match.success) {
    Eigen::Matrix3d relative = rotateCovariance(match.covariance, last_pose.theta());
    Eigen::Matrix3d information = safeInformation(relative);
    Pose2 measured = last_pose.between(match.pose);
    if (!odometry_edge && !result.wide && options_.degenerate_ratio > 0.0) {
      // Without its odometry edge, the step is known along a bare corridor's axis only as
      // the odometry knew it, to within how far the odometry missed the match (a stall or
      // a slip): the edge carries that, or the graph comes apart there and any look-alike
      // place along the axis fits a loop closure.
      const double missed = (match.pose.translation() - prediction.pose.translation()).norm();
      Eigen::Matrix3d doubted = odometry_covariance;
      doubted.topLeftCorner<2, 2>() += missed * missed * Eigen::Matrix2d::Identity();
      const Eigen::Matrix3d along =
          odometryWhereDegenerate(information, safeInformation(doubted), options_.degenerate_ratio);
      if (!along.isZero()) {
        information += along;
        relative = information.inverse();
        measured = last_pose.between(pose);
      }
    }
    appendEdge(from, to, measured, information, floor::EdgeKind::kScanMatch);
    step_covariance =
        odometry_edge
            ? Eigen::Matrix3d((relative.inverse() + odometry_covariance.inverse()).inverse())
            : relative;
  }
  covariance_ =
      geometry::composeCovariance(last_pose, covariance_, last_pose.between(pose), step_covariance);
  result.status = ScanStatus::kNode;
  result.node_id = to;

  if (options_.loop_closure.enabled && ++s.nodes_since_attempt >= options_.loop_closure.every_n_nodes) {
    s.nodes_since_attempt = 0;
    if (tryLoopClosure(points)) {
      result.loop_closed = true;
      result.pose = floor_graph_.nodes.back().pose;
    }
  }
  return result;
}

void FloorSlam::appendNode(const sensor::LaserScan& scan, const Pose2& odometry, const Pose2& pose,
                           bool starts_run) {
  Impl& s = *impl_;
  floor::FloorNode node;
  node.id = floor_graph_.nodes.empty() ? 0 : floor_graph_.nodes.back().id + 1;
  node.stamp = scan.stamp;
  node.pose = pose;
  node.first_pose = pose;
  node.odometry = odometry;
  node.scan = scan;
  pose_graph_.addNode(node.id, pose, /*fixed=*/floor_graph_.nodes.empty(), floor_graph_.floor_id,
                      floor_graph_.floor_height);
  floor_graph_.nodes.push_back(std::move(node));
  ++stats_.nodes;
  if (starts_run) {
    s.chain_start = floor_graph_.nodes.size() - 1;
    s.run_starts.push_back(s.chain_start);
  }
  if (++s.nodes_since_rebuild >= options_.local_map.rebuild_every_n_nodes || pose_graph_.numNodes() <= 1)
    s.local_dirty = true;
  s.floor_target_valid = false;
  last_pose_ = pose;
}

std::size_t FloorSlam::appendEdge(int from, int to, const Pose2& z, const Eigen::Matrix3d& info,
                                  floor::EdgeKind kind) {
  floor::FloorEdge e{from, to, z, info, kind};
  pose_graph_.addEdge(from, to, z, info, toGraphKind(kind));
  if (from >= 0 && to == from + 1) {  // node ids are their indices
    auto& steps = impl_->steps;
    if (steps.size() <= static_cast<std::size_t>(from)) steps.resize(from + 1);
    steps[from].information += info;
    steps[from].weighted += info * z.vector();
  }
  floor_graph_.edges.push_back(e);
  impl_->update_edges.push_back(e);
  return pose_graph_.numEdges() - 1;
}

void FloorSlam::finish() {
  Impl& s = *impl_;
  const auto w = static_cast<std::size_t>(options_.successor_match_nodes);
  const std::size_t n = floor_graph_.nodes.size();
  if (w > 0 && n > w && s.successors_matched + w < n) {
    optimize();  // the successors' maps at the best poses the graph knows
    for (std::size_t k = s.successors_matched; k + w < n; ++k) matchAgainstSuccessors(k);
    // The last w nodes have too few successors now; after a return to this floor their
    // successors would start a new run, so they are never matched.
    s.successors_matched = n;
  }
  optimize();
}

bool FloorSlam::matchAgainstSuccessors(std::size_t k) {
  Impl& s = *impl_;
  const auto w = static_cast<std::size_t>(options_.successor_match_nodes);
  const std::size_t end = k + 1 + w;
  if (end > floor_graph_.nodes.size()) return false;
  // A jump or a relocalisation between the node and its last successor: not one run.
  if (std::any_of(s.run_starts.begin(), s.run_starts.end(),
                  [&](std::size_t start) { return start > k && start < end; }))
    return false;
  grid::OccupancyGrid grid;
  const MatchTarget target = buildTarget(floor_graph_, k + 1, end, options_.local_map,
                                         options_.local_map.pyramid_levels, s.matcher, &grid);
  const floor::FloorNode& node = floor_graph_.nodes[k];
  // The scan sees places behind its successors that none of them saw; its points there would
  // pull the match onto the walls they did see (forward: 0.1 m per step on infinite-corridor).
  const MatchResult match = s.matcher.match(
      target,
      pointsWhereObserved(
          filterPoints(node.scan.pointsInRobotFrame(), options_.matcher.point_filter_distance),
          node.pose, grid),
      node.pose);
  if (!match.success) return false;
  const floor::FloorNode& next = floor_graph_.nodes[k + 1];
  const Eigen::Matrix3d information =
      options_.successor_match_weight *
      safeInformation(rotateCovariance(match.covariance, next.pose.theta()));
  appendEdge(next.id, node.id, next.pose.between(match.pose), information,
             floor::EdgeKind::kScanMatch);
  ++stats_.successor_matches;
  return true;
}

}  // namespace storey::mapping
