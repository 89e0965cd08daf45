#include "storey/mapping/floor_slam.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "storey/common/log.h"

namespace storey::mapping {

using common::str;
using geometry::Pose2;

namespace {

constexpr int kWideSearchLevels = 7;  // pyramid depth for loop closure and relocalisation

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

// The matched step from the last node, with its position along each direction where the
// match's information is below `ratio` times the odometry step's replaced by the two
// fused by their information (at the match's heading).
//
// Standard deviation along the least certain horizontal axis of a pose covariance (m).
double largestTranslationStddev(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance.topLeftCorner<2, 2>());
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

// Degeneracy: in a bare corridor the match knows less along the axis than odometry does,
// and its correlative result there lags at the local map's frontier (the ring of
// FloorSlam.LoopClosureCorrectsDrift stood still for 15 m). Elsewhere, and in heading, the
// step stays the match's (fusing those too followed odometry's noise: infinite-corridor
// nearby 0.45° -> 0.62°, the office test's worst 0.17 m).
Pose2 withOdometryWhereDegenerate(const Pose2& matched, const Eigen::Matrix3d& match_information,
                                  const Pose2& odometry, const Eigen::Matrix3d& odometry_information, double ratio) {
  const Eigen::Matrix2d match_info = match_information.topLeftCorner<2, 2>();
  const Eigen::Matrix2d odometry_info = odometry_information.topLeftCorner<2, 2>();
  const Eigen::Vector2d fused = (odometry_info + match_info)
                                    .ldlt()
                                    .solve(odometry_info * odometry.translation() + match_info * matched.translation());
  Eigen::Vector2d position = matched.translation();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> directions(match_info);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d v = directions.eigenvectors().col(k);
    if (directions.eigenvalues()(k) < ratio * v.dot(odometry_info * v)) position += v * v.dot(fused - position);
  }
  return Pose2(position.x(), position.y(), matched.theta());
}

// Whether a match with this covariance (map frame) claims to know its place along `offset`
// to better than the offset's length (sigma_factor σ along it), unlike a match along a
// bare corridor's axis, whose σ there spans such an offset.
bool pinsAlong(const Eigen::Matrix3d& covariance, const Eigen::Vector2d& offset, double sigma_factor) {
  const Eigen::Vector2d direction = offset.normalized();
  const double sigma = std::sqrt(std::max(0.0, direction.dot(covariance.topLeftCorner<2, 2>() * direction)));
  return sigma_factor * sigma < offset.norm();
}

}  // namespace

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

struct FloorSlam::Impl {
  explicit Impl(const FloorSlamOptions& o)
      : tracker(o.odometry, TrackingWindows{o.matcher.linear_window, o.matcher.angular_window, o.max_linear_window,
                                            o.max_angular_window, o.node.min_translation, o.node.min_rotation}),
        matcher(o.matcher),
        loop_matcher(o.loop_closure.matcher),
        optimizer(o.optimizer),
        full_weight_optimizer(withoutRobustKernels(o.optimizer)) {
    ScanMatcherOptions reloc = o.loop_closure.matcher;
    reloc.angular_step = o.relocalization.angular_step;
    reloc.min_score = o.relocalization.min_score;
    reloc.translation_penalty = 0.0;
    reloc.rotation_penalty = 0.0;
    reloc.max_lookups = 0.0;  // a search of the whole floor, made once per arrival
    reloc_matcher = ScanMatcher(reloc);
    ScanMatcherOptions loop = o.loop_closure.matcher;
    loop.min_score = std::min(loop.min_score, o.loop_closure.min_score);
    loop_matcher = ScanMatcher(loop);
    ScanMatcherOptions polish = loop;
    polish.point_refinement = true;
    polish_matcher = ScanMatcher(polish);
    loop.translation_penalty = 0.0;  // a cluster's rival anywhere in the region counts alike
    loop.rotation_penalty = 0.0;
    loop.min_score = 0.05;  // scores are compared with each other, not with a bar
    verify_matcher = ScanMatcher(loop);
  }
  Tracker tracker;
  ScanMatcher matcher;
  ScanMatcher loop_matcher;
  ScanMatcher polish_matcher;  // the loop matcher's options, refining on points
  ScanMatcher reloc_matcher;
  ScanMatcher verify_matcher;  // a cluster's scans over the region its graph allows
  graph::Optimizer optimizer;
  graph::Optimizer full_weight_optimizer;  // a cluster's correction first, before the kernels
  MatchTarget local_target;
  bool local_dirty = true;
  int nodes_since_rebuild = 0;
  MatchTarget floor_target;  // whole floor, for relocalisation
  bool floor_target_valid = false;
  // The last loop-closure attempt's candidate map: nodes [first, end) around `centre`, at
  // the poses they had when it was built.
  struct LoopTarget {
    MatchTarget target;
    std::size_t first = 0, end = 0;
    int centre = -1;
    std::vector<Pose2> poses;
  } loop_target;

  bool have_last = false;
  double last_stamp = 0.0;
  std::size_t beam_count = 0;
  // Whether the odometry agreed with the matches at the last node (tracker.h): the odometry
  // between two such nodes is an edge; a step into or out of a stall is not.
  bool last_node_odometry_agrees = true;
  std::size_t chain_start = 0;  // first node of the current run of tracked nodes
  std::vector<std::size_t> run_starts;  // every such first node, in order
  std::size_t successors_matched = 0;   // nodes before this one were tried (at finish)
  int nodes_since_attempt = 0;
  // Relocalisation state.
  Pose2 reloc_guess;
  bool reloc_have_odometry = false;
  Pose2 reloc_odometry;
  int reloc_attempts = 0;
  // Each step between consecutive nodes (k -> k+1, in node k's frame) as its edges
  // measured it: their information and information-weighted measurements, whose quotient is
  // the step's fused measurement. Closures are checked against each other through chains of
  // these, not through the nodes' current poses: between optimisations the poses are the
  // tracker's, which in a bare corridor may not have moved where odometry did.
  struct Step {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  };
  std::vector<Step> steps;
  // Matched closures within the cluster window, held or accepted: the attempts (indices
  // into loop_attempts_, which hold their nodes, measurement and information).
  struct Hypothesis {
    std::size_t attempt = 0;
    bool accepted = false;
  };
  std::vector<Hypothesis> hypotheses;
  // Pending update.
  std::size_t update_nodes_from = 0;
  std::vector<floor::FloorEdge> update_edges;
  bool poses_changed = false;
};

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

namespace {

// The map of nodes [first, last) for `matcher`: their scans in an occupancy grid
// (likelihood field and pyramid for the search) and, where the matcher refines on points
// (and point_cell_size is not 0), as points; a matcher that refines on the field would
// never look at them.
MatchTarget buildTarget(const floor::FloorGraph& graph, const std::vector<std::size_t>& indices,
                        const LocalMapOptions& o, int pyramid_levels, const ScanMatcher& matcher,
                        grid::OccupancyGrid* grid_out = nullptr) {
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
                        grid::OccupancyGrid* grid_out = nullptr) {
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

}  // namespace

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
    if (caught_up.success && (!match.success || caught_up.correlative_score > match.correlative_score)) {
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
        search(buildTarget(floor_graph_, n - lm.retry_nodes, n, lm, lm.pyramid_levels, s.matcher), prediction);
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
    MatchResult wide = s.matcher.match(s.local_target, points, around_last.pose, around_last.linear_window,
                                       around_last.angular_window);
    const bool sure = wide.success &&
                      3.0 * largestTranslationStddev(wide.covariance) <= options_.matcher.linear_window &&
                      3.0 * std::sqrt(std::max(0.0, wide.covariance(2, 2))) <= options_.matcher.angular_window;
    if (sure) {
      ++stats_.wide_matches;
      result.wide = true;
      match = wide;
      prediction = around_last;
      common::logWarn(str("floor_slam: the scan at ", scan.stamp, " matched ",
                          s.tracker.predict(odometry).pose.between(wide.pose).translation().norm(), " m from where ",
                          "odometry put it; that odometry step is not trusted"));
    }
  }

  Pose2 pose = prediction.pose;
  bool odometry_agrees = true;
  if (match.success) {
    // Along a direction where the match knows less than the prediction (a bare corridor's
    // axis), the two fused by their information; elsewhere the match's.
    pose = options_.degenerate_ratio > 0.0 && !result.wide
               ? withOdometryWhereDegenerate(match.pose, safeInformation(match.covariance), prediction.pose,
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
                    : Eigen::Matrix3d((safeInformation(match.covariance) + safeInformation(prediction.step_covariance))
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
  if (match.success) ++stats_.matched;
  else ++stats_.match_failures;

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
    appendEdge(from, to, odometry_step, safeInformation(odometry_covariance), floor::EdgeKind::kOdometry);
  Eigen::Matrix3d step_covariance = odometry_covariance;
  if (match.success) {
    const Eigen::Matrix3d relative = rotateCovariance(match.covariance, last_pose.theta());
    appendEdge(from, to, last_pose.between(match.pose), safeInformation(relative), floor::EdgeKind::kScanMatch);
    step_covariance = odometry_edge ? Eigen::Matrix3d((relative.inverse() + odometry_covariance.inverse()).inverse())
                                    : relative;
  }
  covariance_ = geometry::composeCovariance(last_pose, covariance_, last_pose.between(pose), step_covariance);
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

bool FloorSlam::tryLoopClosure(const std::vector<Eigen::Vector2d>& points) {
  Impl& s = *impl_;
  const LoopClosureOptions& o = options_.loop_closure;
  const std::size_t n = floor_graph_.nodes.size();
  if (n <= static_cast<std::size_t>(o.min_node_gap)) return false;
  const floor::FloorNode& current = floor_graph_.nodes.back();
  // Search radius from the current pose's uncertainty.
  const double sigma_xy = largestTranslationStddev(covariance_);
  const double sigma_theta = std::sqrt(std::max(0.0, covariance_(2, 2)));
  const double radius = std::min(o.max_search_radius, o.search_radius + o.sigma_factor * sigma_xy);
  const std::size_t last_candidate = n - 1 - o.min_node_gap;
  // A held closure that a region check moved (its cluster's scans fit best there) says where
  // the robot is better than a graph that far off: later attempts search where it puts
  // them, so that closures agreeing with it can be found.
  Pose2 prediction = current.pose;
  bool followed = false;
  if (o.follow_relocated) {
    for (auto h = s.hypotheses.rbegin(); h != s.hypotheses.rend(); ++h) {
      const LoopClosureAttempt& held = loop_attempts_[h->attempt];
      if (h->accepted || !held.relocated || held.node < current.id - o.cluster_window) continue;
      UncertainPose since;
      if (chainBetween(static_cast<std::size_t>(held.node), n - 1, &since)) {
        prediction = floor_graph_.nodes[held.candidate].pose * held.measurement * since.pose;
        followed = true;
      }
      break;
    }
  }
  const int best = floor_graph_.nearestNodeIndex(prediction.translation(), last_candidate + 1);
  if (best < 0 || (floor_graph_.nodes[best].pose.translation() - prediction.translation()).norm() > radius)
    return false;
  ++stats_.loop_attempts;
  loop_attempts_.emplace_back();
  const std::size_t attempt_index = loop_attempts_.size() - 1;
  LoopClosureAttempt& attempt = loop_attempts_.back();
  attempt.node = current.id;
  attempt.candidate = floor_graph_.nodes[best].id;
  attempt.predicted = floor_graph_.nodes[best].pose.between(current.pose);
  const MatchTarget& target = loopTarget(best, last_candidate);
  const double linear = std::min(o.max_linear_window, o.linear_window + o.sigma_factor * sigma_xy);
  const double angular = std::min(o.max_angular_window, o.angular_window + o.sigma_factor * sigma_theta);
  attempt.sigma = sigma_xy;
  attempt.followed = followed;
  attempt.linear_window = linear;
  attempt.angular_window = angular;
  // Ties the closure to `old` at `pose` of the current node.
  auto tie = [&](const floor::FloorNode& old, const Pose2& pose, const Eigen::Matrix3d& covariance) {
    attempt.candidate = old.id;
    attempt.predicted = old.pose.between(current.pose);
    attempt.measurement = old.pose.between(pose);
    attempt.information = safeInformation(rotateCovariance(covariance, old.pose.theta()));
  };
  // The cluster's scans fitted better at another place of the region: the closure claims
  // that place, tied to the old node nearest it.
  auto relocate = [&](const ClusterCheck& check) {
    attempt.relocated = true;
    tie(floor_graph_.nodes[floor_graph_.nearestNodeIndex(check.pose.translation(), last_candidate + 1)],
        check.pose, check.covariance);
  };
  MatchResult match = s.loop_matcher.match(target, points, prediction, linear, angular);
  if (match.success) attempt.score = match.score;
  if (!match.success || match.score < o.min_score) return false;
  if (o.point_polish_translation > 0.0 && !target.points().empty()) {
    const MatchResult polished = s.polish_matcher.refineOnPoints(target, points, match.pose);
    const Pose2 moved = match.pose.between(polished.pose);
    if (polished.success && polished.pose.isFinite() &&
        moved.translation().norm() <= o.point_polish_translation &&
        std::abs(moved.theta()) <= o.point_polish_rotation)
      match.pose = polished.pose;
  }

  const Eigen::Matrix3d covariance = match.covariance;
  // A closure that will wait for company (a correction too large to stand alone) and that
  // knows where it is along the line it moved (unlike a match along a bare corridor's axis)
  // is tied to the node of the candidate map nearest where the scan matched, not the one
  // nearest a prediction far off: a cluster's spread then counts the places really matched.
  const Eigen::Vector2d shift = match.pose.translation() - prediction.translation();
  const bool retie = o.cluster_size > 1 && shift.norm() > o.single_max_translation &&
                     pinsAlong(covariance, shift, o.sigma_factor);
  int anchor = best;
  if (retie) {  // the candidate map may be a reused one that ends before `best`
    const Eigen::Vector2d matched = match.pose.translation();
    const auto squared = [&](int i) { return (floor_graph_.nodes[i].pose.translation() - matched).squaredNorm(); };
    const int in_map = floor_graph_.nearestNodeIndex(matched, s.loop_target.first, s.loop_target.end);
    if (in_map >= 0 && squared(in_map) < squared(anchor)) anchor = in_map;
  }
  tie(floor_graph_.nodes[anchor], match.pose, covariance);

  // Hypotheses whose newer node has left the window are no longer compared.
  const int oldest = current.id - o.cluster_window;
  s.hypotheses.erase(std::remove_if(s.hypotheses.begin(), s.hypotheses.end(),
                                    [&](const Impl::Hypothesis& x) { return loop_attempts_[x.attempt].node < oldest; }),
                     s.hypotheses.end());
  s.hypotheses.push_back({attempt_index, false});
  const std::size_t newest = s.hypotheses.size() - 1;

  // A small correction the optimised graph agrees with (a short loop, little drift): in at
  // once. A large one alone could be a similar place that a graph uncertain enough bends to.
  const Pose2 correction = attempt.correction();
  bool small = o.cluster_size <= 1 || (correction.translation().norm() <= o.single_max_translation &&
                                       std::abs(correction.theta()) <= o.single_max_rotation);
  // A graph too uncertain for the window agrees with whatever lies near its prediction, and
  // a prediction metres off along a corridor has a look-alike there: alone, a closure must
  // then be the only place in the window its scan fits; otherwise it waits for company.
  const double unique_window = o.single_unique_window > 0.0
                                   ? std::min(o.single_unique_window, o.max_linear_window)
                                   : o.max_linear_window;
  if (small && o.cluster_size > 1 && o.single_unique_distance > 0.0 && linear >= unique_window) {
    const MatchResult rival =
        s.loop_matcher.bestElsewhere(target, points, prediction, linear, angular, match.pose.translation(),
                                     o.single_unique_distance, o.single_unique_ratio * match.correlative_score);
    // A rival the closure's own uncertainty already spans (along a bare corridor's axis) is
    // what it claims; only a closure that claims to know better waits.
    if (rival.exhausted || (rival.success && pinsAlong(covariance, rival.pose.translation() - match.pose.translation(), o.sigma_factor))) {
      small = false;
      attempt.not_unique = true;
    }
  }
  if (small && addClosures({newest}, /*bend_first=*/false)) return true;
  auto reject = [&] {  // a wrong match (e.g. a similar room), or a cluster the graph cannot take
    ++stats_.loop_rejected_inconsistent;
    attempt.outcome = LoopOutcome::kInconsistent;
    s.hypotheses.pop_back();
    return false;
  };
  if (o.cluster_size <= 1) return reject();
  // Otherwise it waits for closures that agree with it.
  attempt.outcome = LoopOutcome::kUnconfirmed;
  // Matches against one small place of the old map share its ambiguities (the corner of a
  // bare corridor fits a scan two metres off as well, match after match): a cluster must
  // tie places of the old map at least cluster_min_spread apart.
  auto place = [&](std::size_t i) {
    return floor_graph_.nodes[loop_attempts_[s.hypotheses[i].attempt].candidate].pose.translation();
  };
  // A second pass when the first cluster's scans fitted better elsewhere: the newest closure
  // then claims that place and may complete a cluster of closures so relocated.
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<std::size_t> cluster = agreeingCluster();
    double spread = 0.0;
    for (std::size_t i : cluster)
      for (std::size_t j : cluster) spread = std::max(spread, (place(i) - place(j)).norm());
    if (cluster.size() < static_cast<std::size_t>(o.cluster_size) || spread < o.cluster_min_spread) return false;
    if (o.cluster_verify_window > 0.0) {
      const ClusterCheck check = checkCluster(cluster, last_candidate);
      if (!check.unique) {
        ++stats_.loop_clusters_ambiguous;
        if (!check.better_elsewhere || attempt.relocated) {
          attempt.outcome = LoopOutcome::kAmbiguous;
          s.hypotheses.pop_back();
          return false;
        }
        relocate(check);
        continue;
      }
    }
    std::vector<std::size_t> held;
    for (std::size_t i : cluster)
      if (!s.hypotheses[i].accepted) held.push_back(i);
    if (addClosures(held, /*bend_first=*/true)) {
      ++stats_.loop_clusters;
      return true;
    }
    return reject();  // dropping the newest: the others may still agree with later ones
  }
  return false;  // relocated, held for company
}

FloorSlam::ClusterCheck FloorSlam::checkCluster(const std::vector<std::size_t>& cluster, std::size_t last_candidate) {
  Impl& s = *impl_;
  const LoopClosureOptions& o = options_.loop_closure;
  const LoopClosureAttempt& newest = loop_attempts_[s.hypotheses[cluster.back()].attempt];
  const floor::FloorNode& current = floor_graph_.nodes[newest.node];
  // The newest scan and those before it, as the graph places them relative to the newest
  // node, thinned to one point per cell (more would only weigh long walls more). Coarse
  // cells and a coarse map: the question is which stretch of corridor, not the last cm
  // (20 m of scans over a 60 m square at 5 cm cost a second; so, tens of ms).
  const double cell = 0.2;
  const double resolution = 0.1;
  std::unordered_set<std::uint64_t> occupied;
  std::vector<Eigen::Vector2d> points;
  double extent = 0.0;
  // A cell's two indices in one key, through unsigned so negative indices are defined.
  const auto cellIndex = [&](double v) {
    return static_cast<std::uint64_t>(static_cast<std::uint32_t>(static_cast<std::int32_t>(std::floor(v / cell))));
  };
  auto inRange = [&](const floor::FloorNode& node) {  // as the maps insert them
    std::vector<Eigen::Vector2d> near;
    for (const auto& p : node.scan.pointsInRobotFrame())
      if (p.norm() <= options_.local_map.max_insert_range) near.push_back(p);
    return near;
  };
  for (int k = std::max(0, newest.node - o.cluster_verify_nodes); k <= newest.node; ++k) {
    const floor::FloorNode& node = floor_graph_.nodes[k];
    const Pose2 relative = current.pose.between(node.pose);
    extent = std::max(extent, relative.translation().norm());
    for (const auto& p : inRange(node)) {
      const Eigen::Vector2d q = relative.transformPoint(p);
      const std::uint64_t key = (cellIndex(q.x()) << 32) | cellIndex(q.y());
      if (occupied.insert(key).second) points.push_back(q);
    }
  }
  const double window = std::min(o.cluster_verify_window, o.linear_window + o.sigma_factor * newest.sigma);
  // The old map wherever those scans could lie (the window, their extent and a margin).
  std::vector<std::size_t> region;
  for (std::size_t i = 0; i <= last_candidate; ++i)
    if ((floor_graph_.nodes[i].pose.translation() - current.pose.translation()).norm() <= window + extent + 2.0)
      region.push_back(i);
  LocalMapOptions coarse = options_.local_map;
  coarse.resolution = resolution;
  const MatchTarget target = buildTarget(floor_graph_, region, coarse, kWideSearchLevels - 1, s.verify_matcher);
  const Pose2 claimed = floor_graph_.nodes[newest.candidate].pose * newest.measurement;
  const MatchResult at_cluster =
      s.verify_matcher.match(target, points, claimed, o.cluster_verify_distance, newest.angular_window);
  const double own = at_cluster.success ? at_cluster.correlative_score : 0.0;
  const MatchResult elsewhere =
      s.verify_matcher.bestElsewhere(target, points, current.pose, window, newest.angular_window,
                                     claimed.translation(), o.cluster_verify_distance, o.cluster_verify_ratio * own);
  common::logDebug(str("floor_slam: cluster of ", cluster.size(), " at node ", newest.node, " scores ", own,
                       elsewhere.success ? str("; elsewhere ", elsewhere.correlative_score, " at ",
                                               (elsewhere.pose.translation() - claimed.translation()).norm(), " m")
                                         : std::string("; nothing elsewhere")));
  ClusterCheck check;
  check.unique = at_cluster.success && !elsewhere.success && !elsewhere.exhausted;
  if (elsewhere.success && elsewhere.correlative_score > own) {
    // The newest scan alone, refined there: a closure like the others (the joined scans'
    // information would count the chain between them as exact).
    const MatchResult there = s.loop_matcher.match(target, inRange(current), elsewhere.pose, 0.3, 0.1);
    if (there.success && there.score >= o.min_score) {
      check.better_elsewhere = true;
      check.pose = there.pose;
      check.covariance = there.covariance;
    }
  }
  return check;
}

bool FloorSlam::chainBetween(std::size_t i, std::size_t j, UncertainPose* out) const {
  const std::size_t first = std::min(i, j), last = std::max(i, j);
  const auto& steps = impl_->steps;
  std::vector<UncertainPose> fused;
  for (std::size_t k = first; k < last; ++k) {
    if (k >= steps.size() || !graph::informationProblem(steps[k].information).empty()) return false;
    const Eigen::Matrix3d covariance = steps[k].information.inverse();
    fused.push_back({Pose2(covariance * steps[k].weighted), covariance});
  }
  UncertainPose chain = composeChain(fused);
  if (i > j) {  // the other way round
    const Eigen::Matrix3d jacobian = geometry::inverseJacobian(chain.pose);
    chain.covariance = jacobian * chain.covariance * jacobian.transpose();
    chain.pose = chain.pose.inverse();
  }
  *out = chain;
  return true;
}

std::vector<std::size_t> FloorSlam::agreeingCluster() const {
  const LoopClosureOptions& o = options_.loop_closure;
  std::vector<const LoopClosureAttempt*> closures;
  std::vector<UncertainPose> measured;  // each closure's measurement with its covariance
  for (const auto& h : impl_->hypotheses) {
    closures.push_back(&loop_attempts_[h.attempt]);
    measured.push_back({closures.back()->measurement, closures.back()->information.inverse()});
  }
  const std::size_t count = closures.size();
  std::vector<std::vector<char>> agree(count, std::vector<char>(count, 0));
  for (std::size_t p = 0; p < count; ++p)
    for (std::size_t q = p + 1; q < count; ++q) {
      const LoopClosureAttempt& cp = *closures[p];
      const LoopClosureAttempt& cq = *closures[q];
      // Older nodes farther apart than the window are on other passes: not compared.
      if (std::abs(cp.candidate - cq.candidate) > o.cluster_window) continue;
      UncertainPose old, recent;
      if (!chainBetween(cp.candidate, cq.candidate, &old) || !chainBetween(cp.node, cq.node, &recent)) continue;
      agree[p][q] = agree[q][p] = closurePairChi2(old, measured[p], recent, measured[q]) <= o.cluster_chi2 ? 1 : 0;
    }
  const std::vector<int> clique = largestCliqueContaining(agree, static_cast<int>(count) - 1);
  return std::vector<std::size_t>(clique.begin(), clique.end());
}

bool FloorSlam::addClosures(const std::vector<std::size_t>& members, bool bend_first) {
  Impl& s = *impl_;
  const LoopClosureOptions& o = options_.loop_closure;
  std::vector<Pose2> backup;
  backup.reserve(pose_graph_.numNodes());
  for (const auto& node : pose_graph_.nodes()) backup.push_back(node.pose);
  std::vector<std::size_t> edges;
  for (std::size_t m : members) {
    const LoopClosureAttempt& c = loop_attempts_[s.hypotheses[m].attempt];
    edges.push_back(pose_graph_.addEdge(c.candidate, c.node, c.measurement, c.information, graph::EdgeKind::kLoopClosure));
  }
  auto undo = [&] {
    for (std::size_t e : edges) pose_graph_.setEdgeEnabled(e, false);
    for (std::size_t i = 0; i < backup.size(); ++i) pose_graph_.setPoseAt(i, backup[i]);
  };
  try {
    if (bend_first) {
      s.full_weight_optimizer.optimize(pose_graph_);
      ++stats_.optimizations;
    }
    s.optimizer.optimize(pose_graph_);
    ++stats_.optimizations;
  } catch (const std::exception& e) {
    common::logWarn(str("floor_slam: optimisation after a loop closure failed: ", e.what()));
    undo();
    return false;
  }
  bool consistent = true;
  for (std::size_t k = 0; k < members.size(); ++k) {
    LoopClosureAttempt& c = loop_attempts_[s.hypotheses[members[k]].attempt];
    c.chi2 = pose_graph_.edgeChi2(edges[k]);
    if (!(c.chi2 <= o.max_chi2)) consistent = false;
  }
  if (!consistent) {
    const LoopClosureAttempt& newest = loop_attempts_[s.hypotheses[members.back()].attempt];
    common::logDebug(str("floor_slam: loop closure ", newest.candidate, " -> ", newest.node, " not taken (chi2 ",
                         newest.chi2, ", ", members.size(), " together)"));
    undo();
    return false;
  }
  for (std::size_t m : members) {
    s.hypotheses[m].accepted = true;
    ++stats_.loop_closures;
    LoopClosureAttempt& c = loop_attempts_[s.hypotheses[m].attempt];
    c.outcome = LoopOutcome::kAccepted;
    c.together = static_cast<int>(members.size());
    common::logDebug(str("floor_slam: loop closure ", c.candidate, " -> ", c.node, " accepted (score ", c.score,
                         ", chi2 ", c.chi2, ", ", members.size(), " together)"));
    floor::FloorEdge e{c.candidate, c.node, c.measurement, c.information, floor::EdgeKind::kLoopClosure};
    floor_graph_.edges.push_back(e);
    s.update_edges.push_back(e);
  }
  const Pose2 before = floor_graph_.nodes.back().pose;
  for (auto& node : floor_graph_.nodes) node.pose = pose_graph_.node(node.id).pose;
  const Pose2 correction = floor_graph_.nodes.back().pose * before.inverse();
  s.tracker.correct(correction);
  last_pose_ = correction * last_pose_;
  s.local_dirty = true;
  s.floor_target_valid = false;
  s.poses_changed = true;
  const graph::NodeId current = floor_graph_.nodes.back().id;
  try {
    const auto marginals = s.optimizer.marginalCovariances(pose_graph_, {current});
    const Eigen::Matrix3d cov = marginals.at(current);
    if (cov.allFinite()) covariance_ = cov;
  } catch (const std::exception& ex) {
    common::logDebug(str("floor_slam: no marginal covariance: ", ex.what()));
  }
  return true;
}

const MatchTarget& FloorSlam::loopTarget(int candidate, std::size_t last_candidate) {
  Impl::LoopTarget& cached = impl_->loop_target;
  const LoopClosureOptions& o = options_.loop_closure;
  auto unmoved = [&] {
    if (cached.end > floor_graph_.nodes.size()) return false;
    for (std::size_t i = cached.first; i < cached.end; ++i) {
      const Pose2& now = floor_graph_.nodes[i].pose;
      const Pose2& then = cached.poses[i - cached.first];
      if (now.x() != then.x() || now.y() != then.y() || now.theta() != then.theta()) return false;
    }
    return true;
  };
  if (cached.centre >= 0 && std::abs(candidate - cached.centre) <= o.submap_reuse_nodes && unmoved())
    return cached.target;
  cached.first = candidate > o.submap_half_nodes ? candidate - o.submap_half_nodes : 0;
  cached.end = std::min(last_candidate + 1, static_cast<std::size_t>(candidate + o.submap_half_nodes + 1));
  cached.centre = candidate;
  cached.poses.clear();
  for (std::size_t i = cached.first; i < cached.end; ++i) cached.poses.push_back(floor_graph_.nodes[i].pose);
  cached.target =
      buildTarget(floor_graph_, cached.first, cached.end, options_.local_map, kWideSearchLevels,
                  o.point_polish_translation > 0.0 ? impl_->polish_matcher : impl_->loop_matcher);
  ++stats_.loop_maps_built;
  return cached.target;
}

int FloorSlam::resumeLocalized(const std::vector<GlobalRelocalizer::Buffered>& scans, const Pose2& pose,
                               const Eigen::Matrix3d& covariance) {
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
    const Pose2 prediction = poses[j + 1] * scans[keep[j + 1]].odometry.between(scans[keep[j]].odometry);
    const std::vector<Eigen::Vector2d> points =
        filterPoints(scans[keep[j]].scan.pointsInRobotFrame(), options_.matcher.point_filter_distance);
    const MatchResult match = s.matcher.match(target, points, prediction);
    if (match.success && match.score >= options_.loop_closure.min_score) {
      placed[j] = Placed::kTied;
      poses[j] = match.pose;
      covariances[j] = match.covariance;
    } else {
      const MatchResult tracked =
          s.matcher.match(buildLocalTarget(chain, options_.local_map, s.matcher), points, prediction);
      placed[j] = tracked.success ? Placed::kTracked : Placed::kOdometry;
      poses[j] = tracked.success ? tracked.pose : prediction;
      if (tracked.success) covariances[j] = tracked.covariance;
    }
    addToChain(j);
  }
  std::vector<int> anchors(keep.size(), -1);
  for (std::size_t j = 0; j < keep.size(); ++j)
    if (placed[j] == Placed::kTied) anchors[j] = floor_graph_.nearestNodeIndex(poses[j].translation());
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
  const MatchResult match = s.reloc_matcher.match(s.floor_target, points, guess, o.linear_window, o.angular_window);
  ++s.reloc_attempts;
  const bool found = match.success && match.score >= o.min_score;
  if (!found && s.reloc_attempts < o.max_attempts) {
    result.status = ScanStatus::kRejected;
    result.reason = str("relocalising (attempt ", s.reloc_attempts, "): ", match.success ? "score too low" : match.problem);
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
    common::logWarn(str("floor_slam: could not localise on floor ", floor_graph_.floor_id, " after ",
                        s.reloc_attempts, " scans; resuming at the expected arrival pose"));
    cov = Eigen::Vector3d(1.0, 1.0, 0.25).asDiagonal();
  }
  const int nearest = floor_graph_.nearestNodeIndex(pose.translation());
  const floor::FloorNode anchor = floor_graph_.nodes[nearest];
  appendNode(scan, odometry, pose, /*starts_run=*/true);
  const Eigen::Matrix3d info = safeInformation(rotateCovariance(cov, anchor.pose.theta()));
  appendEdge(anchor.id, floor_graph_.nodes.back().id, anchor.pose.between(pose), info, floor::EdgeKind::kLoopClosure);
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
