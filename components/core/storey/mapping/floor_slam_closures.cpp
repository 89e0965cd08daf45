// FloorSlam's loop closures: the search, clusters of closures that agree, the region check.
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
  if (best < 0 ||
      (floor_graph_.nodes[best].pose.translation() - prediction.translation()).norm() > radius)
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
  const double angular =
      std::min(o.max_angular_window, o.angular_window + o.sigma_factor * sigma_theta);
  attempt.sigma = sigma_xy;
  attempt.followed = followed;
  attempt.linear_window = linear;
  attempt.angular_window = angular;
  // Ties the closure to `old` at `pose` of the current node.
  auto tie = [&](const floor::FloorNode& old, const Pose2& pose,
                 const Eigen::Matrix3d& covariance) {
    attempt.candidate = old.id;
    attempt.predicted = old.pose.between(current.pose);
    attempt.measurement = old.pose.between(pose);
    attempt.information = safeInformation(rotateCovariance(covariance, old.pose.theta()));
  };
  // The cluster's scans fitted better at another place of the region: the closure claims
  // that place, tied to the old node nearest it.
  auto relocate = [&](const ClusterCheck& check) {
    attempt.relocated = true;
    tie(floor_graph_
            .nodes[floor_graph_.nearestNodeIndex(check.pose.translation(), last_candidate + 1)],
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
    const auto squared = [&](int i) {
      return (floor_graph_.nodes[i].pose.translation() - matched).squaredNorm();
    };
    const int in_map =
        floor_graph_.nearestNodeIndex(matched, s.loop_target.first, s.loop_target.end);
    if (in_map >= 0 && squared(in_map) < squared(anchor)) anchor = in_map;
  }
  tie(floor_graph_.nodes[anchor], match.pose, covariance);

  // Hypotheses whose newer node has left the window are no longer compared.
  const int oldest = current.id - o.cluster_window;
  s.hypotheses.erase(std::remove_if(s.hypotheses.begin(), s.hypotheses.end(),
                                    [&](const Impl::Hypothesis& x) {
                                      return loop_attempts_[x.attempt].node < oldest;
                                    }),
                     s.hypotheses.end());
  s.hypotheses.push_back({attempt_index, false});
  const std::size_t newest = s.hypotheses.size() - 1;

  // A small correction the optimised graph agrees with (a short loop, little drift): in at
  // once. A large one alone could be a similar place that a graph uncertain enough bends to.
  const Pose2 correction = attempt.correction();
  bool small =
      o.cluster_size <= 1 || (correction.translation().norm() <= o.single_max_translation &&
                              std::abs(correction.theta()) <= o.single_max_rotation);
  // A graph too uncertain for the window agrees with whatever lies near its prediction, and
  // a prediction metres off along a corridor has a look-alike there: alone, a closure must
  // then be the only place in the window its scan fits; otherwise it waits for company.
  const double unique_window = o.single_unique_window > 0.0
                                   ? std::min(o.single_unique_window, o.max_linear_window)
                                   : o.max_linear_window;
  if (small && o.cluster_size > 1 && o.single_unique_distance > 0.0 && linear >= unique_window) {
    const MatchResult rival = s.loop_matcher.bestElsewhere(
        target, points, prediction, linear, angular, match.pose.translation(),
        o.single_unique_distance, o.single_unique_ratio * match.correlative_score);
    // A rival the closure's own uncertainty already spans (along a bare corridor's axis) is
    // what it claims; only a closure that claims to know better waits.
    if (rival.exhausted ||
        (rival.success && pinsAlong(covariance, rival.pose.translation() - match.pose.translation(),
                                    o.sigma_factor))) {
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
    if (cluster.size() < static_cast<std::size_t>(o.cluster_size) || spread < o.cluster_min_spread)
      return false;
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

FloorSlam::ClusterCheck FloorSlam::checkCluster(const std::vector<std::size_t>& cluster,
                                                std::size_t last_candidate) {
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
    return static_cast<std::uint64_t>(
        static_cast<std::uint32_t>(static_cast<std::int32_t>(std::floor(v / cell))));
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
  const double window =
      std::min(o.cluster_verify_window, o.linear_window + o.sigma_factor * newest.sigma);
  // The old map wherever those scans could lie (the window, their extent and a margin).
  std::vector<std::size_t> region;
  for (std::size_t i = 0; i <= last_candidate; ++i)
    if ((floor_graph_.nodes[i].pose.translation() - current.pose.translation()).norm() <=
        window + extent + 2.0)
      region.push_back(i);
  LocalMapOptions coarse = options_.local_map;
  coarse.resolution = resolution;
  const MatchTarget target =
      buildTarget(floor_graph_, region, coarse, kWideSearchLevels - 1, s.verify_matcher);
  const Pose2 claimed = floor_graph_.nodes[newest.candidate].pose * newest.measurement;
  const MatchResult at_cluster = s.verify_matcher.match(
      target, points, claimed, o.cluster_verify_distance, newest.angular_window);
  const double own = at_cluster.success ? at_cluster.correlative_score : 0.0;
  const MatchResult elsewhere = s.verify_matcher.bestElsewhere(
      target, points, current.pose, window, newest.angular_window, claimed.translation(),
      o.cluster_verify_distance, o.cluster_verify_ratio * own);
  common::logDebug(str(
      "floor_slam: cluster of ", cluster.size(), " at node ", newest.node, " scores ", own,
      elsewhere.success ? str("; elsewhere ", elsewhere.correlative_score, " at ",
                              (elsewhere.pose.translation() - claimed.translation()).norm(), " m")
                        : std::string("; nothing elsewhere")));
  ClusterCheck check;
  check.unique = at_cluster.success && !elsewhere.success && !elsewhere.exhausted;
  if (elsewhere.success && elsewhere.correlative_score > own) {
    // The newest scan alone, refined there: a closure like the others (the joined scans'
    // information would count the chain between them as exact).
    const MatchResult there =
        s.loop_matcher.match(target, inRange(current), elsewhere.pose, 0.3, 0.1);
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
      if (!chainBetween(cp.candidate, cq.candidate, &old) ||
          !chainBetween(cp.node, cq.node, &recent))
        continue;
      agree[p][q] = agree[q][p] =
          closurePairChi2(old, measured[p], recent, measured[q]) <= o.cluster_chi2 ? 1 : 0;
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
    edges.push_back(pose_graph_.addEdge(c.candidate, c.node, c.measurement, c.information,
                                        graph::EdgeKind::kLoopClosure));
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
    common::logDebug(str("floor_slam: loop closure ", newest.candidate, " -> ", newest.node,
                         " not taken (chi2 ", newest.chi2, ", ", members.size(), " together)"));
    undo();
    return false;
  }
  for (std::size_t m : members) {
    s.hypotheses[m].accepted = true;
    ++stats_.loop_closures;
    LoopClosureAttempt& c = loop_attempts_[s.hypotheses[m].attempt];
    c.outcome = LoopOutcome::kAccepted;
    c.together = static_cast<int>(members.size());
    common::logDebug(str("floor_slam: loop closure ", c.candidate, " -> ", c.node,
                         " accepted (score ", c.score, ", chi2 ", c.chi2, ", ", members.size(),
                         " together)"));
    floor::FloorEdge e{c.candidate, c.node, c.measurement, c.information,
                       floor::EdgeKind::kLoopClosure};
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
  if (cached.centre >= 0 && std::abs(candidate - cached.centre) <= o.submap_reuse_nodes &&
      unmoved())
    return cached.target;
  cached.first = candidate > o.submap_half_nodes ? candidate - o.submap_half_nodes : 0;
  cached.end =
      std::min(last_candidate + 1, static_cast<std::size_t>(candidate + o.submap_half_nodes + 1));
  cached.centre = candidate;
  cached.poses.clear();
  for (std::size_t i = cached.first; i < cached.end; ++i)
    cached.poses.push_back(floor_graph_.nodes[i].pose);
  cached.target =
      buildTarget(floor_graph_, cached.first, cached.end, options_.local_map, kWideSearchLevels,
                  o.point_polish_translation > 0.0 ? impl_->polish_matcher : impl_->loop_matcher);
  ++stats_.loop_maps_built;
  return cached.target;
}

}  // namespace storey::mapping
