// Alignment refinement: scans against a likelihood field (Gauss-Newton) and against a
// point map (point-to-line), and the whole-floor fit that tells rival alignments apart.
#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "storey/common/log.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/floor_matcher_internal.h"
#include "storey/matching/retraction.h"

namespace storey::matching {

using namespace detail;  // NOLINT(google-build-using-namespace): the stages' shared helpers

double refineAlignment(const grid::LikelihoodField& field, const floor::FloorGraph& graph,
                       const std::vector<std::pair<int, int>>& ranges, int beams, int iterations,
                       Pose2* alignment) {
  // Scan endpoints in g_i's frame.
  std::vector<Eigen::Vector2d> points;
  for (const auto& [first, last] : ranges) {
    for (int n = first; n <= last; ++n) {
      const auto& node = graph.nodes[n];
      for (const auto& p : node.pose.transformPoints(selectBeams(node.scan, beams)))
        points.push_back(p);
    }
  }
  if (points.empty()) return 0.0;
  Pose2 t = *alignment;
  std::vector<Eigen::Vector2d> placed;  // the points at the pose being scored, reused
  auto meanScore = [&](const Pose2& a) {
    a.transformPoints(points, &placed);
    double s = 0.0;
    for (const auto& w : placed) s += field.interpolatedScore(w);
    return s / static_cast<double>(points.size());
  };
  double current = meanScore(t);
  double lambda = 1e-3;
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    t.transformPoints(points, &placed);
    for (const Eigen::Vector2d& w : placed) {
      Eigen::Vector2d grad;
      const double s = field.interpolatedScore(w, &grad);
      const double r = 1.0 - s;
      // d w / d(tx, ty, theta) for w = R(theta) p + t.
      Eigen::Matrix<double, 2, 3> dw;
      dw << 1, 0, -(w.y() - t.y()), 0, 1, w.x() - t.x();
      const Eigen::RowVector3d j = -grad.transpose() * dw;
      h += j.transpose() * j;
      g += j.transpose() * r;
    }
    Eigen::Matrix3d damped = h;
    damped.diagonal() += lambda * (h.diagonal().array() + 1e-9).matrix();
    const Eigen::Vector3d step = -damped.ldlt().solve(g);
    if (!step.allFinite()) break;
    const Pose2 trial(t.x() + step.x(), t.y() + step.y(), t.theta() + step.z());
    const double trial_score = meanScore(trial);
    if (trial_score >= current) {
      t = trial;
      current = trial_score;
      lambda = std::max(1e-6, lambda * 0.3);
      if (step.head<2>().norm() < 1e-5 && std::abs(step.z()) < 1e-6) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e6) break;
    }
  }
  *alignment = t;
  return current;
}

namespace {

// How a floor's scan points are fitted to another floor's points (the joint alignment,
// and each constraint's own translation).
grid::PointAlignmentOptions pointAlignmentOptions(const FloorMatcherOptions& o) {
  grid::PointAlignmentOptions a;
  a.max_iterations = std::max(1, o.refine_iterations);
  a.max_correspondence_distance = o.point_correspondence_distance;
  a.robust_distance = o.point_robust_distance;
  return a;
}

// `alignment` refined on `points` (scans_graph's frame) against the map's points; false,
// leaving it as it was, when fewer than half the points found a wall or it moved further
// than the likelihood field's refinement can be off.
bool fitOnPoints(const grid::PointMap& map, const std::vector<Eigen::Vector2d>& points,
                 const FloorMatcherOptions& o, Pose2* alignment) {
  if (points.empty()) return false;
  const grid::PointAlignment fit =
      grid::alignToPoints(map, points, *alignment, pointAlignmentOptions(o));
  // The likelihood field's refinement is already within a cell or two: a larger move
  // means the points found other walls, and the field's answer stands.
  const Pose2 moved = alignment->between(fit.pose);
  if (fit.weight_sum < 0.5 * static_cast<double>(points.size()) || !fit.pose.isFinite() ||
      moved.translation().norm() > 2.0 * o.point_correspondence_distance ||
      std::abs(moved.theta()) > o.ransac_rotation_tolerance)
    return false;
  *alignment = fit.pose;
  return true;
}

std::vector<Eigen::Vector2d> scanPoints(const floor::FloorGraph& graph,
                                        const std::vector<std::pair<int, int>>& ranges,
                                        const FloorMatcherOptions& o) {
  std::vector<Eigen::Vector2d> points;
  for (const auto& [first, last] : ranges) {
    const std::vector<Eigen::Vector2d> more =
        floor::floorPoints(graph, static_cast<std::size_t>(first),
                           static_cast<std::size_t>(last) + 1, o.map.max_insert_range);
    points.insert(points.end(), more.begin(), more.end());
  }
  return points;
}

// The whole floor's points where most of them lie on the reference's walls (floors that
// share their layout); otherwise, as where floors share only a lift and its lobby
// (glass3), the ranges' own points: the field's refinement of a few metres of scans is
// off by up to half a degree, which the points resolve.
void refineAlignmentOnPoints(const grid::PointMap& map, const floor::FloorGraph& graph,
                             const std::vector<std::pair<int, int>>& ranges,
                             const FloorMatcherOptions& o, Pose2* alignment) {
  if (map.empty() || ranges.empty()) return;
  if (o.point_refinement_whole_floor) {
    const int count = static_cast<int>(graph.nodes.size());
    if (fitOnPoints(map, scanPoints(graph, {{0, count - 1}}, o), o, alignment)) return;
  }
  fitOnPoints(map, scanPoints(graph, ranges, o), o, alignment);
}

}  // namespace

Pose2 refinedOnScans(const PreparedFloor& map_floor, const floor::FloorGraph& scans_graph,
                     const std::vector<std::pair<int, int>>& ranges, const FloorMatcherOptions& o,
                     Pose2 alignment) {
  refineAlignment(map_floor.map->field(), scans_graph, ranges, o.refine_beams, o.refine_iterations,
                  &alignment);
  refineAlignmentOnPoints(map_floor.points, scans_graph, ranges, o, &alignment);
  return alignment;
}

namespace detail {

double wholeFloorFit(const PreparedFloor& map_floor, const floor::FloorGraph& scans_graph,
                     const FloorMatcherOptions& o, Pose2* alignment) {
  const int count = static_cast<int>(scans_graph.nodes.size());
  return refineAlignment(map_floor.map->field(), scans_graph, {{0, count - 1}},
                         o.refine_beams / 3 + 1, o.refine_iterations, alignment);
}

Pose2 localTranslation(const grid::PointMap& map, const floor::FloorGraph& graph, int first,
                       int last, const Pose2& joint, const FloorMatcherOptions& o) {
  if (map.empty()) return joint;
  const std::vector<Eigen::Vector2d> points =
      floor::floorPoints(graph, static_cast<std::size_t>(first), static_cast<std::size_t>(last) + 1,
                         o.map.max_insert_range);
  grid::PointAlignmentOptions a = pointAlignmentOptions(o);
  a.rotation_prior_weight = 1e9;  // the heading is the joint alignment's, fixed
  const grid::PointAlignment fit = grid::alignToPoints(map, points, joint, a);
  const Pose2 moved = joint.between(fit.pose);
  if (fit.weight_sum < 0.5 * static_cast<double>(points.size()) || !fit.pose.isFinite() ||
      moved.translation().norm() > 2.0 * o.point_correspondence_distance)
    return joint;
  return Pose2(fit.pose.x(), fit.pose.y(), joint.theta());
}

}  // namespace detail

}  // namespace storey::matching
