#include "storey/matching/floor_matcher.h"

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
#include "storey/matching/retraction.h"

namespace storey::matching {

using geometry::normalizeAngle;
using geometry::Pose2;
using localization::FilterState;
using localization::LocalizationMap;
using localization::makeWallModel;
using localization::ParticleFilter;
using localization::readParticleFilterOptions;
using localization::selectBeams;
using localization::WallModel;

FloorMatcherOptions readFloorMatcherOptions(const common::ConfigNode& node) {
  FloorMatcherOptions o;
  if (node.has("filter")) o.filter = readParticleFilterOptions(node.child("filter"));
  if (node.has("map")) o.map = grid::readOccupancyGridOptions(node.child("map"));
  if (node.has("likelihood_field"))
    o.likelihood_field = grid::readLikelihoodFieldOptions(node.child("likelihood_field"));
  o.min_sequence = node.getInt("min_sequence", o.min_sequence, 1, 100000);
  o.max_sequence = node.getInt("max_sequence", o.max_sequence, 1, 100000);
  if (o.max_sequence < o.min_sequence) node.fail("max_sequence", "must be at least min_sequence");
  o.restart_stride = node.getInt("restart_stride", o.restart_stride, 1, 100000);
  o.likelihood_quantile = node.getDouble("likelihood_quantile", o.likelihood_quantile, 0.0, 1.0);
  o.likelihood_scale = node.getDouble("likelihood_scale", o.likelihood_scale, 0.0, 10.0);
  o.learning_particles = node.getInt("learning_particles", o.learning_particles, 10, 1000000);
  o.refine_iterations = node.getInt("refine_iterations", o.refine_iterations, 0, 1000);
  o.refine_beams = node.getInt("refine_beams", o.refine_beams, 1, 100000);
  o.max_refine_correction =
      node.getDouble("max_refine_correction", o.max_refine_correction, 0.0, 100.0);
  o.min_fit = node.getDouble("min_fit", o.min_fit, 0.0, 1.0);
  o.point_cell_size = node.getDouble("point_cell_size", o.point_cell_size, 0.0, 1.0);
  o.point_refinement_whole_floor =
      node.get<bool>("point_refinement_whole_floor", o.point_refinement_whole_floor);
  o.joint_alignment_both_directions =
      node.get<bool>("joint_alignment_both_directions", o.joint_alignment_both_directions);
  o.local_constraint_translation =
      node.get<bool>("local_constraint_translation", o.local_constraint_translation);
  o.point_normal_radius = node.getDouble("point_normal_radius", o.point_normal_radius, 0.01, 5.0);
  o.point_correspondence_distance =
      node.getDouble("point_correspondence_distance", o.point_correspondence_distance, 1e-3, 10.0);
  o.point_robust_distance = node.getDouble("point_robust_distance", o.point_robust_distance, 1e-4, 10.0);
  o.ransac_iterations = node.getInt("ransac_iterations", o.ransac_iterations, 1, 10000000);
  o.ransac_translation_tolerance =
      node.getDouble("ransac_translation_tolerance", o.ransac_translation_tolerance, 1e-4, 100.0);
  o.ransac_rotation_tolerance =
      node.getDouble("ransac_rotation_tolerance", o.ransac_rotation_tolerance, 1e-5, M_PI);
  o.ransac_distortion = node.getDouble("ransac_distortion", o.ransac_distortion, 0.0, 0.1);
  o.min_constraints = node.getInt("min_constraints", o.min_constraints, 1, 100000);
  o.ambiguity_ratio = node.getDouble("ambiguity_ratio", o.ambiguity_ratio, 0.0, 1.0);
  o.ambiguity_fit_margin = node.getDouble("ambiguity_fit_margin", o.ambiguity_fit_margin, 0.0, 1.0);
  o.constraint_sigma_xy = node.getDouble("constraint_sigma_xy", o.constraint_sigma_xy, 1e-6, 100.0);
  o.constraint_sigma_theta =
      node.getDouble("constraint_sigma_theta", o.constraint_sigma_theta, 1e-6, M_PI);
  o.normal_tilt_stddev = node.getDouble("normal_tilt_stddev", o.normal_tilt_stddev, 0.0, 1.0);
  o.max_weak_sigma = node.getDouble("max_weak_sigma", o.max_weak_sigma, 0.0, 100.0);
  o.self_check = node.get<bool>("self_check", o.self_check);
  o.match_self_similar = node.get<bool>("match_self_similar", o.match_self_similar);
  o.match_both_directions = node.get<bool>("match_both_directions", o.match_both_directions);
  o.backwards_sequences = node.get<bool>("backwards_sequences", o.backwards_sequences);
  o.wall_recheck = node.getDouble("wall_recheck", o.wall_recheck, 0.0, 1.0);
  o.same_floor_see_through =
      node.getDouble("same_floor_see_through", o.same_floor_see_through, 0.0, 1.0);
  o.same_floor_through_beams =
      node.getInt("same_floor_through_beams", o.same_floor_through_beams, 1, 10000);
  o.floor_change.radius = node.getDouble("floor_change_radius", o.floor_change.radius, 0.0, 1e4);
  o.floor_change.heading =
      node.getDouble("floor_change_heading", o.floor_change.heading, 0.0, M_PI);
  o.wall_beams = node.getInt("wall_beams", o.wall_beams, 1, 10000);
  o.wall_recheck_max = node.getInt("wall_recheck_max", o.wall_recheck_max, 0, 1000000);
  o.wall_log_p = node.getDouble("wall_log_p", o.wall_log_p, -100.0, 0.0);
  o.threads = node.getInt("threads", o.threads, 1, 256);
  o.seed = static_cast<std::uint64_t>(node.get<std::int64_t>("seed", 1));
  node.finish();
  return o;
}

const char* candidateStatusName(CandidateStatus status) {
  switch (status) {
    case CandidateStatus::kAccepted:
      return "accepted";
    case CandidateStatus::kLowLikelihood:
      return "low_likelihood";
    case CandidateStatus::kPoorFit:
      return "poor_fit";
    case CandidateStatus::kOutlier:
      return "outlier";
    case CandidateStatus::kTooFew:
      return "too_few";
    case CandidateStatus::kAmbiguous:
      return "ambiguous";
    case CandidateStatus::kUnderconstrained:
      return "underconstrained";
    case CandidateStatus::kContradicted:
      return "contradicted";
  }
  return "unknown";
}

const PairResult* MatchResult::pairFor(int graph_id) const {
  const PairResult* last = nullptr;
  for (const auto& p : pairs) {
    if (p.graph_id != graph_id) continue;
    if (p.accepted) return &p;
    last = &p;
  }
  return last;
}

namespace {

// Metres before its endpoint a beam may cross a wall: it may end just past the wall it hit.
constexpr double kWallMargin = 0.3;

// An accepted pair taken back: not accepted, and its accepted candidates kContradicted.
void takeBack(const std::string& candidate_reason, PairResult* p) {
  p->accepted = false;
  for (auto& c : p->candidates)
    if (c.status == CandidateStatus::kAccepted) {
      c.status = CandidateStatus::kContradicted;
      c.reason = candidate_reason;
    }
}

// An accepted pair whose placement two graphs of one floor contradict: taken back, and
// the graph tries no other this pass (sameFloorContradiction).
void withdrawAsContradicted(const std::string& pair_reason, const std::string& candidate_reason,
                            PairResult* p) {
  takeBack(candidate_reason, p);
  p->contradicted = true;
  p->reason = pair_reason;
}

// Deterministic per-job seeds, independent of thread scheduling.
std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = seed ^ (a * 0x9E3779B97F4A7C15ULL) ^ (b * 0xC2B2AE3D27D4EB4FULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Whether a candidate got past the likelihood gate, the refinement and the conditioning
// gate (RANSAC decides the rest).
bool passedGate(CandidateStatus s) {
  return s != CandidateStatus::kLowLikelihood && s != CandidateStatus::kPoorFit &&
         s != CandidateStatus::kUnderconstrained;
}

// A candidate's scans as one node range in graph order, for refineAlignment (a backwards
// sequence's first index is its later node).
std::vector<std::pair<int, int>> orderedRange(const Candidate& c) {
  return {{std::min(c.first_index, c.last_index), std::max(c.first_index, c.last_index)}};
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos = q * static_cast<double>(values.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(values.size() - 1, lo + 1);
  return values[lo] + (values[hi] - values[lo]) * (pos - static_cast<double>(lo));
}

// Does alignment `a` place node `node_pose` where alignment `b` does?
bool agrees(const Pose2& a, const Pose2& b, const Pose2& node_pose, double tol_t, double tol_r) {
  const Pose2 pa = a * node_pose, pb = b * node_pose;
  return (pa.translation() - pb.translation()).norm() <= tol_t &&
         std::abs(normalizeAngle(pa.theta() - pb.theta())) <= tol_r;
}

// Mean of alignments: translation averaged, heading by circular mean; each weighted by
// `weights` when given (else alike).
Pose2 meanAlignment(const std::vector<Pose2>& poses, const std::vector<double>& weights = {}) {
  double x = 0, y = 0, c = 0, s = 0, n = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const Pose2& p = poses[i];
    const double w = weights.empty() ? 1.0 : weights[i];
    x += w * p.x();
    y += w * p.y();
    c += w * std::cos(p.theta());
    s += w * std::sin(p.theta());
    n += w;
  }
  return Pose2(x / n, y / n, std::atan2(s, c));
}

// Scans in a set of node ranges [first, last].
int scanCount(const std::vector<std::pair<int, int>>& ranges) {
  int n = 0;
  for (const auto& [first, last] : ranges) n += last - first + 1;
  return n;
}

// The candidates of `set` whose scans are pairwise disjoint, as many as possible (per
// source graph, earliest-ending first): a time-reversed sequence and a forward one over
// the same scans are one piece of evidence, not two. Two sequences that share only their
// end scan count as two (the paper's own sequences do: k <- k + d), so a forward pass
// ending where a time-reversed one ends is not lost; but not when that scan is node k
// of both, which would give the same constraint twice.
std::vector<std::size_t> disjointSubset(const std::vector<Candidate>& cands,
                                        std::vector<std::size_t> set) {
  std::sort(set.begin(), set.end(), [&](std::size_t a, std::size_t b) {
    if (cands[a].last_index != cands[b].last_index)
      return cands[a].last_index < cands[b].last_index;
    return a < b;
  });
  std::vector<std::size_t> out;
  // By the graph whose scans were localised: the last kept sequence's end scan, and
  // whether that scan is its node k (a time-reversed sequence's k is its later end).
  std::map<int, std::pair<int, bool>> last_end;
  for (std::size_t i : set) {
    const Candidate& c = cands[i];
    const int source = c.reversed ? c.reference_graph_id : c.graph_id;
    auto& [end, end_is_k] = last_end.emplace(source, std::make_pair(-1, false)).first->second;
    // Sharing the end scan is allowed, unless it is node k of both (one constraint twice).
    if (c.first_index < end || (c.first_index == end && end_is_k && !c.backwards)) continue;
    end = c.last_index;
    end_is_k = c.backwards;
    out.push_back(i);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Largest set of candidates (among `pool`) agreeing with one candidate's alignment,
// counting candidates with overlapping scans once (the set returned is disjoint; `all`,
// when given, receives every candidate agreeing with the winning hypothesis).
std::vector<std::size_t> largestConsistentSet(const std::vector<Candidate>& cands,
                                              const std::vector<std::size_t>& pool,
                                              const floor::FloorGraph& graph,
                                              const FloorMatcherOptions& o, std::mt19937_64* rng,
                                              std::vector<std::size_t>* all = nullptr) {
  std::vector<std::size_t> hypotheses = pool;
  if (hypotheses.size() > static_cast<std::size_t>(o.ransac_iterations)) {
    std::shuffle(hypotheses.begin(), hypotheses.end(), *rng);
    hypotheses.resize(static_cast<std::size_t>(o.ransac_iterations));
  }
  std::vector<std::size_t> best, best_all;
  double best_score = -1.0;
  for (std::size_t h : hypotheses) {
    std::vector<std::size_t> consistent;
    for (std::size_t i : pool) {
      const Pose2& pk = graph.nodes[cands[i].node_index].pose;
      if (agrees(cands[h].alignment, cands[i].alignment, pk, o.ransac_translation_tolerance,
                 o.ransac_rotation_tolerance))
        consistent.push_back(i);
    }
    std::vector<std::size_t> set = disjointSubset(cands, consistent);
    double score = 0.0;
    for (std::size_t i : set) score += cands[i].likelihood;
    if (set.size() > best.size() || (set.size() == best.size() && score > best_score)) {
      best = std::move(set);
      best_all = std::move(consistent);
      best_score = score;
    }
  }
  if (all) *all = std::move(best_all);
  return best;
}

}  // namespace

std::vector<std::size_t> bentFloorCandidates(const std::vector<Candidate>& cands,
                                             const std::vector<std::size_t>& pool,
                                             const std::vector<std::size_t>& core,
                                             const floor::FloorGraph& graph, const FloorMatcherOptions& o) {
  std::vector<std::size_t> out;
  if (o.ransac_distortion <= 0.0 || core.empty()) return out;
  std::vector<Pose2> alignments;
  for (std::size_t i : core) alignments.push_back(cands[i].alignment);
  const Pose2 mean = meanAlignment(alignments);
  for (std::size_t i : pool) {
    if (std::find(core.begin(), core.end(), i) != core.end()) continue;
    const Pose2& pk = graph.nodes[cands[i].node_index].pose;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t j : core)
      nearest = std::min(nearest, (graph.nodes[cands[j].node_index].pose.translation() - pk.translation()).norm());
    if (agrees(mean, cands[i].alignment, pk, o.ransac_translation_tolerance + o.ransac_distortion * nearest,
               o.ransac_rotation_tolerance))
      out.push_back(i);
  }
  return out;
}

double refineAlignment(const grid::LikelihoodField& field, const floor::FloorGraph& graph,
                       const std::vector<std::pair<int, int>>& ranges, int beams, int iterations,
                       Pose2* alignment) {
  // Scan endpoints in g_i's frame.
  std::vector<Eigen::Vector2d> points;
  for (const auto& [first, last] : ranges) {
    for (int n = first; n <= last; ++n) {
      const auto& node = graph.nodes[n];
      for (const auto& p : node.pose.transformPoints(selectBeams(node.scan, beams))) points.push_back(p);
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
    const std::vector<Eigen::Vector2d> more = floor::floorPoints(
        graph, static_cast<std::size_t>(first), static_cast<std::size_t>(last) + 1,
        o.map.max_insert_range);
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

namespace {

// The fit of *all* of `scans_graph`'s scans in map_floor's map, `alignment` (their
// frame into map_floor's) refined from where it is, on a third of the refinement's beams:
// how rival alignments (and a floor's twin) are told apart.
double wholeFloorFit(const PreparedFloor& map_floor, const floor::FloorGraph& scans_graph,
                     const FloorMatcherOptions& o, Pose2* alignment) {
  const int count = static_cast<int>(scans_graph.nodes.size());
  return refineAlignment(map_floor.map->field(), scans_graph, {{0, count - 1}}, o.refine_beams / 3 + 1,
                         o.refine_iterations, alignment);
}

// Whether a second consistent set makes a pair ambiguous. A rival by count (at least
// ambiguity_ratio of the largest set, and 2 or more) stands unless the whole floor fits
// the largest set's alignment better by ambiguity_fit_margin; a smaller second set large
// enough to be accepted alone stands when the whole floor fits it better (along a
// periodic row of rooms more sequences may agree on a place a few rooms off than at the
// true one). `fits()` returns the whole floor's fit at the two sets' alignments; it is
// only called for a rival.
bool secondSetStands(std::size_t best, std::size_t second, const FloorMatcherOptions& o,
                     const std::function<std::pair<double, double>()>& fits) {
  const bool rival_by_count =
      second >= 2 && static_cast<double>(second) >= o.ambiguity_ratio * static_cast<double>(best);
  const bool rival_by_size = static_cast<int>(second) >= o.min_constraints;
  if (!rival_by_count && !rival_by_size) return false;
  const auto [fit_best, fit_second] = fits();
  return rival_by_count ? fit_best < fit_second + o.ambiguity_fit_margin : fit_second > fit_best;
}

// The translation of `joint` that best fits one candidate's own scans (nodes first..last)
// on the reference's points, the heading held at the joint's. A floor graph is not rigid
// (a bare corridor's length is off by a few tenths of a per cent): where this candidate's
// scans lie, the floor may sit a little off the joint alignment, and a constraint that
// says so lets the building graph take up the distortion. Returns `joint` when the fit
// moves further than the points' correspondence reach or rests on too few points.
Pose2 localTranslation(const grid::PointMap& map, const floor::FloorGraph& graph, int first, int last,
                       const Pose2& joint, const FloorMatcherOptions& o) {
  if (map.empty()) return joint;
  const std::vector<Eigen::Vector2d> points = floor::floorPoints(
      graph, static_cast<std::size_t>(first), static_cast<std::size_t>(last) + 1, o.map.max_insert_range);
  grid::PointAlignmentOptions a = pointAlignmentOptions(o);
  a.rotation_prior_weight = 1e9;  // the heading is the joint alignment's, fixed
  const grid::PointAlignment fit = grid::alignToPoints(map, points, joint, a);
  const Pose2 moved = joint.between(fit.pose);
  if (fit.weight_sum < 0.5 * static_cast<double>(points.size()) || !fit.pose.isFinite() ||
      moved.translation().norm() > 2.0 * o.point_correspondence_distance)
    return joint;
  return Pose2(fit.pose.x(), fit.pose.y(), joint.theta());
}

}  // namespace

std::vector<std::uint8_t> solidWalls(const grid::LikelihoodField& field,
                                     const floor::FloorGraph& graph, int beams) {
  const grid::GridFrame& f = field.frame();
  std::vector<std::uint8_t> solid(f.cellCount(), 0);
  for (std::size_t i = 0; i < solid.size(); ++i) solid[i] = field.distance().data[i] <= 0.0f;
  // A cell the floor's own beams passed through is not a wall that is always there (a
  // landing door that opened, a person): clear it. The last cells before each endpoint
  // are spared, so the wall a beam ends on stays.
  const double step = 0.5 * f.resolution, spare = 2.0 * f.resolution;
  for (const auto& node : graph.nodes) {
    const Eigen::Vector2d origin = (node.pose * node.scan.sensor_offset).translation();
    for (const auto& end : node.pose.transformPoints(selectBeams(node.scan, beams))) {
      const Eigen::Vector2d d = end - origin;
      const double length = d.norm();
      if (length <= spare) continue;
      const Eigen::Vector2d u = d / length;
      for (double t = step; t < length - spare; t += step) {
        const Eigen::Vector2i c = f.cellOf(origin + t * u);
        if (f.contains(c.x(), c.y())) solid[f.index(c.x(), c.y())] = 0;
      }
    }
  }
  return solid;
}

namespace {

// Of one node's scan (up to `beams` traced, placed at alignment * pose): how many beams
// cross a cell of `walls` more than `margin` before their endpoint (`through`), of `total`.
struct BeamsThroughWalls {
  std::size_t through = 0, total = 0;
};
BeamsThroughWalls beamsThroughWalls(const grid::GridFrame& f,
                                    const std::vector<std::uint8_t>& walls,
                                    const floor::FloorNode& node, int beams, const Pose2& alignment,
                                    double margin) {
  // Half-cell steps cannot jump over a wall one cell thick.
  const double step = 0.5 * f.resolution;
  BeamsThroughWalls count;
  const Pose2 robot = alignment * node.pose;
  const Eigen::Vector2d origin = (robot * node.scan.sensor_offset).translation();
  for (const Eigen::Vector2d& end : robot.transformPoints(selectBeams(node.scan, beams))) {
    const Eigen::Vector2d d = end - origin;
    const double length = d.norm() - margin;
    ++count.total;
    if (length <= 0.0) continue;
    const Eigen::Vector2d u = d / d.norm();
    for (double t = step; t < length; t += step) {
      const Eigen::Vector2i c = f.cellOf(origin + t * u);
      if (f.contains(c.x(), c.y()) && walls[f.index(c.x(), c.y())]) {
        ++count.through;
        break;
      }
    }
  }
  return count;
}

}  // namespace

double seeThroughFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                          const floor::FloorGraph& graph,
                          const std::vector<std::pair<int, int>>& ranges, int beams,
                          const Pose2& alignment, double margin) {
  std::size_t total = 0, through = 0;
  for (const auto& [first, last] : ranges) {
    for (int n = first; n <= last; ++n) {
      const BeamsThroughWalls count =
          beamsThroughWalls(f, walls, graph.nodes[n], beams, alignment, margin);
      through += count.through;
      total += count.total;
    }
  }
  return total ? static_cast<double>(through) / static_cast<double>(total) : 0.0;
}

double seeThroughScanFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                              const floor::FloorGraph& graph, int beams, const Pose2& alignment,
                              int min_beams) {
  if (graph.nodes.empty()) return 0.0;
  int seeing = 0;
  for (const auto& node : graph.nodes)
    seeing += beamsThroughWalls(f, walls, node, beams, alignment, kWallMargin).through >=
              static_cast<std::size_t>(min_beams);
  return static_cast<double>(seeing) / static_cast<double>(graph.nodes.size());
}

void PreparedFloor::computeWalls(const FloorMatcherOptions& options) const {
  std::call_once(walls_->once, [&] {
    walls_->cells = solidWalls(map->field(), *graph, options.refine_beams);
    walls_->model = makeWallModel(map->frame(), walls_->cells);
  });
}

const std::vector<std::uint8_t>& PreparedFloor::walls(const FloorMatcherOptions& options) const {
  computeWalls(options);
  return walls_->cells;
}

const WallModel& PreparedFloor::wallModel(const FloorMatcherOptions& options) const {
  computeWalls(options);
  return walls_->model;
}

PreparedFloor prepareFloor(const floor::FloorGraph& graph, const FloorMatcherOptions& options) {
  PreparedFloor p;
  p.graph = &graph;
  const grid::OccupancyGrid grid = floor::renderFloorMap(graph, options.map);
  p.map = std::make_unique<LocalizationMap>(grid, options.likelihood_field);
  p.structure = p.map->occupiedCells();
  if (options.point_cell_size > 0.0)
    p.points = grid::PointMap(floor::floorPoints(graph, 0, graph.nodes.size(), options.map.max_insert_range),
                              options.point_cell_size, options.point_normal_radius);
  p.l_min = learnLikelihoodThreshold(
      graph, options, mixSeed(options.seed, 0x1EA2, static_cast<std::uint64_t>(graph.graph_id)));
  return p;
}

double learnLikelihoodThreshold(const floor::FloorGraph& graph, const FloorMatcherOptions& options,
                                std::uint64_t seed) {
  if (graph.nodes.size() < 2) return 0.0;
  floor::FloorGraph even;
  for (std::size_t n = 0; n < graph.nodes.size(); n += 2) even.nodes.push_back(graph.nodes[n]);
  const LocalizationMap map(floor::renderFloorMap(even, options.map), options.likelihood_field);
  ParticleFilter filter(map, options.filter, seed);
  const double sigma_xy = 0.05, sigma_theta = 0.02;
  filter.initializeAround(graph.nodes.front().pose, sigma_xy, sigma_theta,
                          options.learning_particles);
  std::vector<double> values;
  for (std::size_t n = 0; n < graph.nodes.size(); ++n) {
    // Moved by the graph's own relative poses (the mapper knows them): the raw odometry
    // can jump, e.g. across an elevator ride between two visits of the floor, and a lost
    // tracker would teach a meaningless l_min.
    if (n > 0) filter.predict(graph.nodes[n - 1].pose.between(graph.nodes[n].pose));
    const double lt = filter.update(graph.nodes[n].scan);
    if (n % 2 == 1) values.push_back(lt);
    filter.resampleIfNeeded();
  }
  // A tracker that lost its way for a while (a long featureless corridor) must not drag
  // the threshold to nothing: l_min is at least half the median.
  return std::max(quantile(values, options.likelihood_quantile), 0.5 * quantile(values, 0.5));
}

namespace {

// One sequence: `filter` (already initialised) replays the scans at replay positions
// kp, kp+1, ... (node indices `at`) until it converges after at least min_sequence scans
// or max_sequence scans have been used.
struct SequenceRun {
  bool converged = false;
  int mp = 0;  // replay position of the last scan used
  double lt = 0.0;
  FilterState state;
};

template <typename At>
SequenceRun runSequence(ParticleFilter* filter, const floor::FloorGraph& g, At at, int kp,
                        const FloorMatcherOptions& o) {
  const int count = static_cast<int>(g.nodes.size());
  const int end = std::min(count, kp + o.max_sequence);
  SequenceRun run;
  for (run.mp = kp; run.mp < end; ++run.mp) {
    const int n = at(run.mp);
    if (run.mp > kp)
      filter->predict(g.nodes[at(run.mp - 1)].first_pose.between(g.nodes[n].first_pose));
    run.lt = filter->update(g.nodes[n].scan);
    run.state = filter->state();
    if (run.mp - kp + 1 >= o.min_sequence && run.state.converged) {
      run.converged = true;
      return run;
    }
    filter->resampleIfNeeded();
  }
  run.mp = std::max(kp, end - 1);
  return run;
}

// The candidate of a converged sequence from node k = at(kp) to m = at(mp): refined,
// back-propagated to k, gated.
template <typename At>
Candidate makeCandidate(const PreparedFloor& map_floor, const PreparedFloor& scans_floor,
                        double l_min, const FloorMatcherOptions& o, bool backwards, At at, int kp,
                        const SequenceRun& run) {
  const floor::FloorGraph& ref = *map_floor.graph;
  const floor::FloorGraph& g = *scans_floor.graph;
  const int k = at(kp), m = at(run.mp);
  const int first = std::min(k, m), last = std::max(k, m);
  Candidate c;
  c.reference_graph_id = ref.graph_id;
  c.graph_id = g.graph_id;
  c.first_index = first;
  c.last_index = last;
  c.backwards = backwards;
  c.node_index = k;
  c.node_id = g.nodes[k].id;
  c.estimate = run.state.mean;
  c.likelihood = run.lt;
  c.l_min = l_min;
  c.particles = run.state.particles;
  c.mass_within = run.state.mass_within;
  c.dz = g.floor_height - ref.floor_height;
  Pose2 alignment = run.state.mean * g.nodes[m].pose.inverse();
  c.fit = refineAlignment(map_floor.map->field(), g, {{first, last}}, o.refine_beams,
                          o.refine_iterations, &alignment);
  c.alignment = alignment;
  const Pose2 refined_m = alignment * g.nodes[m].pose;
  c.refine_correction = (refined_m.translation() - run.state.mean.translation()).norm();
  const Pose2 x_k = alignment * g.nodes[k].pose;
  const int q = ref.nearestNodeIndex(x_k.translation());
  c.reference_node_id = ref.nodes[q].id;
  c.measurement = ref.nodes[q].pose.between(x_k);
  if (!map_floor.points.empty()) {
    const std::vector<Eigen::Vector2d> points =
        floor::floorPoints(g, static_cast<std::size_t>(first), static_cast<std::size_t>(last) + 1,
                           o.map.max_insert_range);
    grid::PointAlignmentOptions a;
    a.max_iterations = 0;  // the information where the candidate is
    a.max_correspondence_distance = o.point_correspondence_distance;
    a.robust_distance = o.point_robust_distance;
    const grid::PointAlignment fit = grid::alignToPoints(map_floor.points, points, alignment, a);
    // Conditioning where the scans are, not at g_i's origin (often tens of metres away).
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& p : points) centre += p;
    if (!points.empty()) centre = alignment.transformPoint(centre / static_cast<double>(points.size()));
    const grid::TranslationConditioning cond = grid::translationConditioning(
        grid::withoutNormalNoise(fit.information, o.normal_tilt_stddev), alignment.translation() - centre);
    c.information_ratio = cond.ratio;
    c.weak_direction = std::atan2(cond.weak_direction.y(), cond.weak_direction.x());
  }
  const double weak_sigma = c.information_ratio > 0.0 ? o.constraint_sigma_xy / std::sqrt(c.information_ratio)
                                                      : std::numeric_limits<double>::infinity();
  if (run.lt < l_min) {
    c.status = CandidateStatus::kLowLikelihood;
    c.reason = common::str("l_t ", run.lt, " < l_min ", l_min);
  } else if (c.refine_correction > o.max_refine_correction || c.fit < o.min_fit) {
    c.status = CandidateStatus::kPoorFit;
    c.reason = common::str("refinement moved ", c.refine_correction, " m, fit ", c.fit);
  } else if (o.max_weak_sigma > 0.0 && c.information_ratio >= 0.0 && weak_sigma > o.max_weak_sigma) {
    c.status = CandidateStatus::kUnderconstrained;
    c.reason = common::str("its scans pin one direction to sigma ", weak_sigma, " m > ", o.max_weak_sigma,
                           " (information ratio ", c.information_ratio, ")");
  } else {
    c.status = CandidateStatus::kOutlier;  // decided by RANSAC
  }
  return c;
}

// A gated candidate whose beams cross solid walls of the map it was localised in more than
// o.wall_recheck: the likelihood field scores only where beams end, so it may have
// preferred a wrong place (a corridor seen from inside fits both ways round when its open
// end shows rooms the reference lacks). The same scans again from z_k, with the wall model
// in the filter; the candidate is replaced by what that filter finds, or rejected when it
// does not converge. Returns the last replay position used.
int recheckWalls(const PreparedFloor& map_floor, const PreparedFloor& scans_floor, double l_min,
                 const FloorMatcherOptions& o, std::uint64_t seed, Candidate* c,
                 PairResult* counters, std::uint64_t* evaluations) {
  const floor::FloorGraph& g = *scans_floor.graph;
  const int count = static_cast<int>(g.nodes.size());
  const bool backwards = c->backwards;
  auto at = [&](int position) { return backwards ? count - 1 - position : position; };
  const int kp = backwards ? count - 1 - c->node_index : c->node_index;
  const int mp_before = backwards ? count - 1 - c->first_index : c->last_index;
  if (c->status != CandidateStatus::kOutlier) return mp_before;
  c->see_through = seeThroughFraction(map_floor.map->frame(), map_floor.walls(o), g,
                                      {{c->first_index, c->last_index}}, o.refine_beams,
                                      c->alignment, kWallMargin);
  if (c->see_through <= o.wall_recheck) return mp_before;
  if (counters->wall_rechecks >= o.wall_recheck_max) {
    // Unrelated floors give many candidates that see through walls; each recheck is a
    // global localisation with traced beams. Past the budget, such a candidate is dropped:
    // it was suspect, and dropping evidence never adds a wrong constraint.
    c->status = CandidateStatus::kPoorFit;
    c->reason = common::str("sees through walls (", c->see_through, " of beams); ",
                            o.wall_recheck_max, " rechecks already spent on this pair");
    return mp_before;
  }
  ++counters->wall_rechecks;
  ParticleFilter filter(*map_floor.map, o.filter,
                        seed ^ (0x3A11ULL + 977ULL * static_cast<std::uint64_t>(kp)));
  filter.setWallModel(&map_floor.wallModel(o), o.wall_beams, o.wall_log_p, kWallMargin);
  filter.initializeUniform();
  const SequenceRun run = runSequence(&filter, g, at, kp, o);
  *evaluations += filter.beamEvaluations();
  const double first_through = c->see_through;
  if (!run.converged) {
    c->status = CandidateStatus::kPoorFit;
    c->reason = common::str("sees through walls (", first_through,
                            " of beams) and the wall model does not converge");
    return mp_before;
  }
  *c = makeCandidate(map_floor, scans_floor, l_min, o, backwards, at, kp, run);
  c->see_through = seeThroughFraction(map_floor.map->frame(), map_floor.walls(o), g,
                                      {{c->first_index, c->last_index}}, o.refine_beams,
                                      c->alignment, kWallMargin);
  c->reason = common::str("re-localised with the wall model (the first estimate saw through ",
                          first_through, " of beams)", c->reason.empty() ? "" : "; ", c->reason);
  return std::max(mp_before, run.mp);
}

// Algorithm 1's loop: replays `scans`' node scans in `map`'s map from uniform particles,
// one sequence after another, and turns each converged filter into a candidate whose
// alignment is `scans`' frame in `map`'s frame (the caller re-expresses it when the
// direction is reversed). Gated against `l_min`. With `backwards`, the scans are replayed
// last to first (the odometry increments inverted): a sequence then starts where the
// robot ended, so a pass through shared structure at the end of a visit is seen from
// its far end first, as the pass at the start of a visit is forwards. With `walls`, each
// gated candidate goes through recheckWalls.
std::vector<Candidate> localiseSequences(const PreparedFloor& map_floor,
                                         const PreparedFloor& scans_floor, double l_min,
                                         const FloorMatcherOptions& o, std::uint64_t seed,
                                         bool backwards, bool walls, PairResult* counters,
                                         std::uint64_t* evaluations) {
  const floor::FloorGraph& ref = *map_floor.graph;
  const floor::FloorGraph& g = *scans_floor.graph;
  const int count = static_cast<int>(g.nodes.size());
  auto at = [&](int position) { return backwards ? count - 1 - position : position; };
  std::vector<Candidate> out;
  ParticleFilter filter(*map_floor.map, o.filter, seed ^ (backwards ? 0xBAC5EEDULL : 0x5EEDULL));
  int kp = 0;  // positions in replay order; at() gives the node index
  while (kp + o.min_sequence <= count && !ref.nodes.empty()) {
    ++counters->sequences;
    filter.initializeUniform();
    const SequenceRun run = runSequence(&filter, g, at, kp, o);
    if (!run.converged) {
      ++counters->not_converged;
      kp += o.restart_stride;
      continue;
    }
    Candidate c = makeCandidate(map_floor, scans_floor, l_min, o, backwards, at, kp, run);
    int mp = run.mp;
    if (walls)
      mp = recheckWalls(map_floor, scans_floor, l_min, o, seed, &c, counters, evaluations);
    out.push_back(std::move(c));
    kp = mp + 1;
  }
  *evaluations += filter.beamEvaluations();
  return out;
}

// A candidate found by localising g_ref's scans in g_i's map, re-expressed as evidence
// about g_i in g_ref: the alignment is inverted, and the constraint between node k of
// g_ref and the nearest node q of g_i is written from g_ref's node to g_i's node.
Candidate reverseCandidate(const Candidate& r, const floor::FloorGraph& ref,
                           const floor::FloorGraph& g) {
  Candidate c = r;
  c.reversed = true;
  c.reference_graph_id = ref.graph_id;
  c.graph_id = g.graph_id;
  c.alignment = r.alignment.inverse();
  c.dz = -r.dz;
  // r.node_id is node k of g_ref, r.reference_node_id the nearest node q of g_i, and
  // r.measurement is node k in node q's frame.
  int q = 0;
  while (q < static_cast<int>(g.nodes.size()) && g.nodes[q].id != r.reference_node_id) ++q;
  c.node_index = q;
  c.node_id = r.reference_node_id;
  c.reference_node_id = r.node_id;
  c.measurement = r.measurement.inverse();
  return c;
}

// An accepted candidate's weak direction, from the frame of the map its scans were
// localised in (the other graph's; g_i's when reversed, then turned by the alignment of
// g_i in the other graph) to the frame of node q of its measurement.
double weakDirectionAt(const Candidate& c, const Pose2& alignment, const Pose2& q) {
  return geometry::normalizeAngle(c.weak_direction + (c.reversed ? alignment.theta() : 0.0) - q.theta());
}

// Where either floor is self-similar, a gated candidate's alignment A has twins that
// fit as well wherever the scans see only the symmetric part: T_ref·A and A·T_i. The
// candidate stays in RANSAC only if its scans fit the other floor's map worse by
// ambiguity_fit_margin at each twin (refined from there, so a twin gets its best chance)
// than at A; otherwise it is marked ambiguous.
void markTwinCandidates(const PreparedFloor& reference, const PreparedFloor& floor_data,
                        const FloorMatcherOptions& o, PairResult* result) {
  for (Candidate& c : result->candidates) {
    if (c.status != CandidateStatus::kOutlier) continue;
    std::vector<Pose2> twins;
    if (reference.twin) twins.push_back(*reference.twin * c.alignment);
    if (floor_data.twin) twins.push_back(c.alignment * *floor_data.twin);
    // A reversed candidate's scans are g_ref's, localised in g_i's map (the inverse).
    const PreparedFloor& map_floor = c.reversed ? floor_data : reference;
    const floor::FloorGraph& scans = c.reversed ? *reference.graph : *floor_data.graph;
    const std::vector<std::pair<int, int>> range = orderedRange(c);
    Pose2 own = c.reversed ? c.alignment.inverse() : c.alignment;
    const double at_own = refineAlignment(map_floor.map->field(), scans, range, o.refine_beams, 0, &own);
    for (const Pose2& twin : twins) {
      Pose2 placed = c.reversed ? twin.inverse() : twin;
      const double at_twin =
          refineAlignment(map_floor.map->field(), scans, range, o.refine_beams, o.refine_iterations, &placed);
      if (at_own - at_twin > o.ambiguity_fit_margin) continue;
      c.fits_twin = true;
      c.status = CandidateStatus::kAmbiguous;
      c.reason = common::str("a self-similar floor's twin alignment fits its scans about as well (", at_twin,
                             " against ", at_own, ")");
      break;
    }
  }
}

}  // namespace

void decideConsistentSet(const PreparedFloor& reference, const PreparedFloor& floor_data,
                         const FloorMatcherOptions& o, std::mt19937_64* rng_ptr,
                         PairResult* result_ptr) {
  PairResult& result = *result_ptr;
  std::mt19937_64& rng = *rng_ptr;
  const floor::FloorGraph& g = *floor_data.graph;
  if (reference.twin || floor_data.twin) markTwinCandidates(reference, floor_data, o, &result);
  // RANSAC over the candidates that passed the gate.
  std::vector<std::size_t> pool;
  for (std::size_t i = 0; i < result.candidates.size(); ++i)
    if (result.candidates[i].status == CandidateStatus::kOutlier) pool.push_back(i);
  std::vector<std::size_t> best_all;
  std::vector<std::size_t> best = largestConsistentSet(result.candidates, pool, g, o, &rng, &best_all);
  const std::vector<std::size_t> bent = bentFloorCandidates(result.candidates, pool, best_all, g, o);
  if (!bent.empty()) {
    best_all.insert(best_all.end(), bent.begin(), bent.end());
    std::sort(best_all.begin(), best_all.end());
    best = disjointSubset(result.candidates, best_all);
  }
  std::vector<std::size_t> rest, overlapping;
  for (std::size_t i : pool) {
    if (std::find(best_all.begin(), best_all.end(), i) == best_all.end())
      rest.push_back(i);
    else if (std::find(best.begin(), best.end(), i) == best.end())
      overlapping.push_back(i);
  }
  const std::vector<std::size_t> second = largestConsistentSet(result.candidates, rest, g, o, &rng);
  auto markAll = [&](const std::vector<std::size_t>& which, CandidateStatus s,
                     const std::string& why) {
    for (std::size_t i : which) {
      result.candidates[i].status = s;
      result.candidates[i].reason = why;
    }
  };
  // Two consistent sets: the one whose alignment lets *all* of g_i's scans fit the
  // reference map clearly better wins (a periodic layout fits locally, not at its ends);
  // otherwise the floor is ambiguous.
  double fit_best = -1.0, fit_second = -1.0;
  Pose2 align_best, align_second;
  auto wholeFloorFits = [&]() {
    auto fitOf = [&](const std::vector<std::size_t>& set, Pose2* a) {
      std::vector<Pose2> alignments;
      for (std::size_t i : set) alignments.push_back(result.candidates[i].alignment);
      *a = meanAlignment(alignments);
      return wholeFloorFit(reference, g, o, a);
    };
    fit_best = fitOf(best, &align_best);
    fit_second = fitOf(second, &align_second);
    return std::make_pair(fit_best, fit_second);
  };
  if (static_cast<int>(best.size()) < o.min_constraints) {
    result.reason = common::str("largest consistent set has ", best.size(), " of ", pool.size(),
                                " gated candidates (need ", o.min_constraints, ")");
    markAll(pool, CandidateStatus::kTooFew, result.reason);
  } else if (secondSetStands(best.size(), second.size(), o, wholeFloorFits)) {
    result.ambiguous = true;
    result.set_alignments = {align_best, align_second};
    result.reason =
        common::str("ambiguous: two disjoint consistent sets of ", best.size(), " and ",
                    second.size(), " candidates, whole-floor fit ", fit_best, " vs ", fit_second);
    markAll(pool, CandidateStatus::kAmbiguous, result.reason);
  } else {
    result.accepted = true;
    result.reason =
        common::str("accepted: ", best.size(), " consistent of ", pool.size(), " gated candidates");
    if (fit_best >= 0.0)
      result.reason += common::str(" (a second set of ", second.size(),
                                   " loses on whole-floor fit ", fit_best, " vs ", fit_second, ")");
    markAll(rest, CandidateStatus::kOutlier, "disagrees with the largest consistent set");
    markAll(overlapping, CandidateStatus::kOutlier,
            "agrees, but its scans overlap an inlier's (counted once)");
    markAll(best, CandidateStatus::kAccepted, "inlier of the largest consistent set");
    std::vector<Pose2> alignments;
    std::vector<std::pair<int, int>> ranges, reversed_ranges;
    for (std::size_t i : best) {
      const Candidate& c = result.candidates[i];
      alignments.push_back(c.alignment);
      (c.reversed ? reversed_ranges : ranges).emplace_back(c.first_index, c.last_index);
    }
    const bool use_forward = !ranges.empty();
    const bool use_backward = !reversed_ranges.empty() && (!use_forward || o.joint_alignment_both_directions);
    const Pose2 mean = meanAlignment(alignments);
    Pose2 forward = mean, backward = mean;
    if (use_forward) forward = refinedOnScans(reference, g, ranges, o, mean);  // g_i's scans in g_ref's map
    if (use_backward)  // g_ref's scans in g_i's map
      backward = refinedOnScans(floor_data, *reference.graph, reversed_ranges, o, mean.inverse()).inverse();
    const Pose2 joint =
        use_forward && use_backward
            ? combineAlignments(forward, scanCount(ranges), backward, scanCount(reversed_ranges))
            : (use_forward ? forward : backward);
    result.alignment = joint;
    const floor::FloorGraph& ref = *reference.graph;
    const std::string contradiction = sameFloorContradiction(reference, floor_data, joint, o);
    if (!contradiction.empty()) {
      const std::string why = common::str("contradicted: ", best.size(), " consistent of ",
                                          pool.size(), " gated candidates, but ", contradiction);
      withdrawAsContradicted(why, why, &result);
      return;
    }
    // Each accepted constraint is re-expressed through the joint alignment, which fits
    // every inlier's scans at once: one candidate's own refinement may be off by a few
    // tenths of a degree more than RANSAC's tolerance lets through. Not a reversed one:
    // its node of g_i is where g_ref's scans were localised in g_i's map, a local
    // measurement, while the joint alignment places that node by g_i's whole graph (a
    // graph bent by 0.7 degrees along featureless's 127 m corridor put such constraints
    // 0.3-0.4 m off across it).
    for (std::size_t i : best) {
      Candidate& c = result.candidates[i];
      // With the distortion allowance on, any accepted candidate whose node the joint
      // alignment does not place within RANSAC's translation tolerance (those that joined
      // through the allowance, and a core one the refined joint moved away from) is where
      // the rigid floor is not: it keeps its own measurement, as a reversed one does. The
      // allowance is for a floor stretched (metres per metre), not turned: where its own
      // heading is more than RANSAC's rotation tolerance from the joint's, it takes the
      // joint's (a weak candidate a few degrees off, which the joint alignment refined on
      // the inliers' points no longer places within the tolerance, must not turn its node).
      const Pose2& node_pose = g.nodes[c.node_index].pose;
      const bool beyond_joint =
          !c.reversed && o.ransac_distortion > 0.0 &&
          !agrees(joint, c.alignment, node_pose, o.ransac_translation_tolerance, M_PI);
      if (c.reversed || beyond_joint) {
        const Pose2& q = ref.findNode(c.reference_node_id)->pose;
        if (beyond_joint) {
          const Pose2 own = q * c.measurement;
          const double joint_heading = (joint * node_pose).theta();
          if (std::abs(normalizeAngle(own.theta() - joint_heading)) > o.ransac_rotation_tolerance)
            c.measurement = q.between(Pose2(own.x(), own.y(), joint_heading));
        }
        c.weak_direction = weakDirectionAt(c, c.alignment, q);
        continue;
      }
      const Pose2 placed = o.local_constraint_translation
                               ? localTranslation(reference.points, g, c.first_index, c.last_index, joint, o)
                               : joint;
      const Pose2 x = placed * g.nodes[c.node_index].pose;
      const int q = ref.nearestNodeIndex(x.translation());
      c.reference_node_id = ref.nodes[q].id;
      c.measurement = ref.nodes[q].pose.between(x);
      c.weak_direction = weakDirectionAt(c, joint, ref.nodes[q].pose);
    }
  }
}

namespace {

// Gated candidates whose alignment `refuted` refutes leave RANSAC's pool.
void markRefuted(const AlignmentCheck& refuted, std::vector<Candidate>* candidates) {
  if (!refuted) return;
  for (Candidate& c : *candidates) {
    if (c.status != CandidateStatus::kOutlier) continue;
    const std::string why = refuted(c.alignment);
    if (why.empty()) continue;
    c.status = CandidateStatus::kContradicted;
    c.reason = "placed so, " + why;
  }
}

PairResult matchPairDirected(const PreparedFloor& reference, const PreparedFloor& floor_data,
                             const FloorMatcherOptions& o, std::uint64_t seed, bool both_directions,
                             const AlignmentCheck& refuted) {
  const auto start = std::chrono::steady_clock::now();
  const floor::FloorGraph& ref = *reference.graph;
  const floor::FloorGraph& g = *floor_data.graph;
  PairResult result;
  result.reference_graph_id = ref.graph_id;
  result.graph_id = g.graph_id;
  result.l_min = o.likelihood_scale * std::min(reference.l_min, floor_data.l_min);
  std::mt19937_64 rng(seed);
  std::uint64_t evaluations = 0;
  result.candidates = localiseSequences(reference, floor_data, result.l_min, o, seed, false, false,
                                        &result, &evaluations);
  markRefuted(refuted, &result.candidates);
  decideConsistentSet(reference, floor_data, o, &rng, &result);
  if (!result.accepted && both_directions && ref.graph_id != g.graph_id) {
    // Too few or two rival consistent sets: g_ref's scans localised in g_i's map are
    // independent evidence about the same alignment (shared structure that g_i's robot
    // passed only briefly may be where g_ref's robot spent longer).
    PairResult reverse;
    // Gated candidates are decided again with the new evidence; a twin's stays ambiguous
    // (the test would give the same answer, and it must not spend the recheck budget).
    for (Candidate& c : result.candidates)
      if (passedGate(c.status) && !c.fits_twin) c.status = CandidateStatus::kOutlier;
    // The first pass's candidates that saw through walls are rechecked now (the recheck
    // is costly, so only a pair that needs more evidence pays for it).
    for (Candidate& c : result.candidates)
      recheckWalls(reference, floor_data, result.l_min, o, seed, &c, &result, &evaluations);
    // One recheck budget for the pair, whichever direction spends it.
    reverse.wall_rechecks = result.wall_rechecks;
    std::vector<Candidate> back =
        localiseSequences(floor_data, reference, result.l_min, o, seed ^ 0xBAC4ULL, false, true,
                          &reverse, &evaluations);
    result.wall_rechecks = reverse.wall_rechecks;
    if (o.backwards_sequences) {
      // Both floors' scans replayed last to first as well (see localiseSequences).
      std::vector<Candidate> more = localiseSequences(reference, floor_data, result.l_min, o, seed,
                                                      true, true, &result, &evaluations);
      result.candidates.insert(result.candidates.end(), more.begin(), more.end());
      reverse.wall_rechecks = result.wall_rechecks;
      more = localiseSequences(floor_data, reference, result.l_min, o, seed ^ 0xBAC4ULL, true, true,
                               &reverse, &evaluations);
      result.wall_rechecks = reverse.wall_rechecks;
      back.insert(back.end(), more.begin(), more.end());
    }
    for (const Candidate& r : back) result.candidates.push_back(reverseCandidate(r, ref, g));
    result.ambiguous = false;
    result.contradicted = false;
    result.set_alignments.clear();
    markRefuted(refuted, &result.candidates);
    decideConsistentSet(reference, floor_data, o, &rng, &result);
    result.sequences += reverse.sequences;
    result.not_converged += reverse.not_converged;
    result.reversed_candidates = static_cast<int>(back.size());
  }
  result.beam_evaluations = evaluations;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace

// Two graphs of one floor (one floor id: two robots', or a floor mapped again after a
// failed relocalisation) were built from the same walls, so at the right alignment
// neither graph's beams pass through the other's solid walls. A young graph placed a few
// rooms along a periodic row fits there locally, but its beams down the corridor then
// cross the other graph's end walls (and the other's beams its own). Empty when
// `alignment` (g_i's frame in g_ref's) is consistent, else what contradicts it.
std::string sameFloorContradiction(const PreparedFloor& reference, const PreparedFloor& floor_data,
                                   const Pose2& alignment, const FloorMatcherOptions& o) {
  const floor::FloorGraph& ref = *reference.graph;
  const floor::FloorGraph& g = *floor_data.graph;
  if (o.same_floor_see_through >= 1.0 || ref.graph_id == g.graph_id || ref.floor_id != g.floor_id ||
      ref.nodes.empty() || g.nodes.empty())
    return {};
  const double g_in_ref =
      seeThroughScanFraction(reference.map->frame(), reference.walls(o), g, o.refine_beams,
                             alignment, o.same_floor_through_beams);
  const double ref_in_g =
      seeThroughScanFraction(floor_data.map->frame(), floor_data.walls(o), ref, o.refine_beams,
                             alignment.inverse(), o.same_floor_through_beams);
  if (std::min(g_in_ref, ref_in_g) <= o.same_floor_see_through) return {};
  return common::str("graphs ", g.graph_id, " and ", ref.graph_id, " are of floor ", g.floor_id,
                     ", and ", g_in_ref, " of ", g.graph_id, "'s scans see through ", ref.graph_id,
                     "'s walls, ", ref_in_g, " the other way (at most ", o.same_floor_see_through,
                     ")");
}

PairResult matchPair(const PreparedFloor& reference, const PreparedFloor& floor_data,
                     const FloorMatcherOptions& o, std::uint64_t seed,
                     const AlignmentCheck& refuted) {
  return matchPairDirected(reference, floor_data, o, seed, o.match_both_directions, refuted);
}

namespace {

// How many of the candidates `home` (sequences of a floor localised in its own map at the
// identity) fit that map worse by more than ambiguity_fit_margin when placed by `twin`.
int refutingSequences(const PreparedFloor& floor_data, const std::vector<Candidate>& candidates,
                      const std::vector<std::size_t>& home, const Pose2& twin, const FloorMatcherOptions& o) {
  int refuting = 0;
  for (std::size_t i : home) {
    const Candidate& c = candidates[i];
    const std::vector<std::pair<int, int>> range = orderedRange(c);
    Pose2 identity, placed = twin;
    const double at_home =
        refineAlignment(floor_data.map->field(), *floor_data.graph, range, o.refine_beams, 0, &identity);
    const double at_twin =
        refineAlignment(floor_data.map->field(), *floor_data.graph, range, o.refine_beams, 0, &placed);
    refuting += at_home - at_twin > o.ambiguity_fit_margin;
  }
  return refuting;
}

}  // namespace

FloorCheck checkSelfSimilarity(const PreparedFloor& floor_data, const FloorMatcherOptions& o,
                               std::uint64_t seed) {
  FloorCheck check;
  check.graph_id = floor_data.graph->graph_id;
  check.structure = floor_data.structure;
  check.l_min = floor_data.l_min;
  const PairResult own = matchPairDirected(floor_data, floor_data, o, seed, false, {});
  std::vector<std::size_t> elsewhere, at_home;
  for (std::size_t i = 0; i < own.candidates.size(); ++i) {
    const Candidate& c = own.candidates[i];
    if (!passedGate(c.status)) continue;
    const Pose2& pk = floor_data.graph->nodes[c.node_index].pose;
    if (agrees(Pose2(), c.alignment, pk, o.ransac_translation_tolerance,
               o.ransac_rotation_tolerance))
      at_home.push_back(i);
    else
      elsewhere.push_back(i);
  }
  check.at_identity = static_cast<int>(at_home.size());
  std::mt19937_64 rng(seed);
  const std::vector<std::size_t> twin =
      largestConsistentSet(own.candidates, elsewhere, *floor_data.graph, o, &rng);
  check.elsewhere = static_cast<int>(twin.size());
  check.self_similar =
      check.elsewhere >= 2 &&
      check.elsewhere >= o.ambiguity_ratio * static_cast<double>(check.at_identity);
  if (check.self_similar) {
    // As for two rival sets in a pair: a floor is self-similar only if the other
    // alignment fits *all* its scans about as well as the identity. A symmetric floor
    // maps onto itself; a corridor whose ends differ fits only locally.
    std::vector<Pose2> alignments;
    for (std::size_t i : twin) alignments.push_back(own.candidates[i].alignment);
    Pose2 other = meanAlignment(alignments), identity;
    check.fit_elsewhere = wholeFloorFit(floor_data, *floor_data.graph, o, &other);
    check.fit_identity = wholeFloorFit(floor_data, *floor_data.graph, o, &identity);
    check.other = other;
    // A twin must also explain the sequences that found their own place: placed by it,
    // their scans fit about as well as at home on a symmetric floor (all but those at the
    // one asymmetric door), but clearly worse where the floor has structure of its own,
    // as at the ends and the lobby of a bare corridor. The whole-floor fit above cannot
    // see those few: a long bare corridor fits either way round and dilutes them.
    const int refuting = refutingSequences(floor_data, own.candidates, at_home, other, o);
    check.refuted = refuting;
    check.self_similar =
        check.fit_identity < check.fit_elsewhere + o.ambiguity_fit_margin &&
        refuting < std::max(2.0, o.ambiguity_ratio * static_cast<double>(check.elsewhere));
  }
  return check;
}

namespace {

// Runs jobs 0..n-1 on up to `threads` threads.
template <typename F>
void parallelFor(int n, int threads, F job) {
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i = next++; i < n; i = next++) job(i);
  };
  const int t = std::max(1, std::min(threads, n));
  std::vector<std::thread> pool;
  for (int i = 1; i < t; ++i) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}

}  // namespace

// The loop T_ref,i = T_r * T_r,i closed over two pairs that each had too few (see the header).
PairResult combineThroughAligned(const PairResult& direct, const PairResult& via, const Pose2& t_r,
                                 const PreparedFloor& reference, const PreparedFloor& aligned,
                                 const PreparedFloor& floor_data, const FloorMatcherOptions& o,
                                 std::uint64_t seed) {
  const floor::FloorGraph& g = *floor_data.graph;
  PairResult out;
  out.reference_graph_id = direct.reference_graph_id;
  out.graph_id = direct.graph_id;
  out.l_min = direct.l_min;
  out.candidates = direct.candidates;
  const std::size_t first_via = out.candidates.size();
  out.candidates.insert(out.candidates.end(), via.candidates.begin(), via.candidates.end());
  // Alignments in the reference's frame, for RANSAC.
  std::vector<Candidate> in_reference = out.candidates;
  for (std::size_t i = first_via; i < in_reference.size(); ++i)
    in_reference[i].alignment = t_r * in_reference[i].alignment;
  std::vector<std::size_t> pool;
  for (std::size_t i = 0; i < out.candidates.size(); ++i) {
    // Not a candidate whose own set was contradicted (a floor change or another graph of
    // its floor): that placement is already refuted.
    const CandidateStatus s = out.candidates[i].status;
    if (passedGate(s) && s != CandidateStatus::kContradicted) {
      pool.push_back(i);
      out.candidates[i].status = CandidateStatus::kOutlier;
    }
  }
  std::mt19937_64 rng(seed);
  std::vector<std::size_t> best_all;
  const std::vector<std::size_t> best =
      largestConsistentSet(in_reference, pool, g, o, &rng, &best_all);
  std::vector<std::size_t> rest;
  for (std::size_t i : pool)
    if (std::find(best_all.begin(), best_all.end(), i) == best_all.end()) rest.push_back(i);
  const std::vector<std::size_t> second = largestConsistentSet(in_reference, rest, g, o, &rng);
  int from_via = 0;
  for (std::size_t i : best) from_via += i >= first_via;
  auto markAll = [&](const std::vector<std::size_t>& which, CandidateStatus st,
                     const std::string& why) {
    for (std::size_t i : which) {
      out.candidates[i].status = st;
      out.candidates[i].reason = why;
    }
  };
  const std::string via_name = common::str("graph ", via.reference_graph_id);
  if (static_cast<int>(best.size()) < o.min_constraints) {
    out.reason =
        common::str("with ", via_name, " (aligned): largest consistent set has ", best.size(),
                    " of ", pool.size(), " gated candidates (need ", o.min_constraints, ")");
    markAll(pool, CandidateStatus::kTooFew, out.reason);
    return out;
  }
  // The rival rule of decideConsistentSet, the whole floor fitted in both maps (g_i shares
  // structure with each): the sum of its fits in the reference's and in the aligned graph's.
  double fit_best = -1.0, fit_second = -1.0;
  auto wholeFloorFits = [&]() {
    auto fitOf = [&](const std::vector<std::size_t>& set) {
      std::vector<Pose2> alignments;
      for (std::size_t i : set) alignments.push_back(in_reference[i].alignment);
      Pose2 in_ref = meanAlignment(alignments);
      Pose2 in_r = t_r.inverse() * in_ref;
      return wholeFloorFit(reference, g, o, &in_ref) + wholeFloorFit(aligned, g, o, &in_r);
    };
    fit_best = fitOf(best);
    fit_second = fitOf(second);
    return std::make_pair(fit_best, fit_second);
  };
  if (secondSetStands(best.size(), second.size(), o, wholeFloorFits)) {
    out.ambiguous = true;
    out.reason = common::str("with ", via_name, " (aligned): two disjoint consistent sets of ",
                             best.size(), " and ", second.size(), ", whole-floor fit ", fit_best,
                             " vs ", fit_second);
    markAll(pool, CandidateStatus::kAmbiguous, out.reason);
    return out;
  }
  out.accepted = true;
  out.reason = common::str("accepted with ", via_name, " (aligned to the reference): ", best.size(),
                           " consistent of ", pool.size(), " gated candidates, ", from_via,
                           " of them against ", via_name);
  markAll(rest, CandidateStatus::kOutlier, "disagrees with the largest consistent set");
  for (std::size_t i : best_all)
    if (std::find(best.begin(), best.end(), i) == best.end())
      markAll({i}, CandidateStatus::kOutlier,
              "agrees, but its scans overlap an inlier's (counted once)");
  markAll(best, CandidateStatus::kAccepted, "inlier of the consistent set over both graphs");
  // The joint alignment: refined on the inliers' scans in the map each was localised in
  // (g_i's in the reference's or the aligned graph's map; theirs in g_i's, inverted), and
  // the refinements combined by scan count. Without joint_alignment_both_directions, on
  // g_i's scans in the reference's map alone, as before; without any, their mean stands.
  std::vector<Pose2> alignments;
  for (std::size_t i : best) alignments.push_back(in_reference[i].alignment);
  const Pose2 mean = meanAlignment(alignments);
  const floor::FloorGraph& r_graph = *aligned.graph;
  // Node ranges per (map, direction): [0] g_i in the reference, [1] the reference in g_i,
  // [2] g_i in the aligned graph, [3] the aligned graph in g_i.
  std::vector<std::pair<int, int>> ranges[4];
  for (std::size_t i : best) {
    const Candidate& c = out.candidates[i];
    const int group = (i >= first_via ? 2 : 0) + (c.reversed ? 1 : 0);
    ranges[group].emplace_back(c.first_index, c.last_index);
  }
  std::vector<Pose2> refined;
  std::vector<double> weights;
  auto add = [&](int group, const Pose2& a) {
    refined.push_back(a);
    weights.push_back(scanCount(ranges[group]));
  };
  if (!ranges[0].empty()) add(0, refinedOnScans(reference, g, ranges[0], o, mean));
  if (o.joint_alignment_both_directions) {
    const Pose2 mean_in_r = t_r.inverse() * mean;
    if (!ranges[1].empty())
      add(1, refinedOnScans(floor_data, *reference.graph, ranges[1], o, mean.inverse()).inverse());
    if (!ranges[2].empty()) add(2, t_r * refinedOnScans(aligned, g, ranges[2], o, mean_in_r));
    if (!ranges[3].empty())
      add(3, t_r * refinedOnScans(floor_data, r_graph, ranges[3], o, mean_in_r.inverse()).inverse());
  }
  const Pose2 joint = refined.empty() ? mean : meanAlignment(refined, weights);
  const Pose2 joint_in_r = t_r.inverse() * joint;
  std::string contradiction = sameFloorContradiction(reference, floor_data, joint, o);
  if (contradiction.empty())
    contradiction = sameFloorContradiction(aligned, floor_data, joint_in_r, o);
  if (!contradiction.empty()) {
    const std::string why =
        common::str("with ", via_name, " (aligned): contradicted: ", contradiction);
    withdrawAsContradicted(why, why, &out);
    return out;
  }
  out.alignment = joint;
  for (std::size_t i : best) {
    Candidate& c = out.candidates[i];
    const bool via_r = i >= first_via;
    const floor::FloorGraph& other = via_r ? *aligned.graph : *reference.graph;
    if (c.reversed) {  // its own, local measurement (as in decideConsistentSet)
      c.weak_direction = weakDirectionAt(c, c.alignment, other.findNode(c.reference_node_id)->pose);
      continue;
    }
    const Pose2 x = (via_r ? joint_in_r : joint) * g.nodes[c.node_index].pose;
    const int q = other.nearestNodeIndex(x.translation());
    c.reference_node_id = other.nodes[q].id;
    c.measurement = other.nodes[q].pose.between(x);
    c.weak_direction = weakDirectionAt(c, via_r ? joint_in_r : joint, other.nodes[q].pose);
  }
  return out;
}

Pose2 combineAlignments(const Pose2& a, double weight_a, const Pose2& b, double weight_b) {
  return meanAlignment({a, b}, {weight_a, weight_b});
}

Eigen::Matrix3d constraintInformation(const Candidate& c, const FloorMatcherOptions& o) {
  // Never quite zero along the weak direction: a floor held only by corridor constraints
  // stays solvable (its along-corridor place then rests on its other constraints).
  constexpr double kMinRatio = 1e-4;
  const double ratio = c.information_ratio < 0.0 ? 1.0 : std::clamp(c.information_ratio, kMinRatio, 1.0);
  const Eigen::Vector2d weak(std::cos(c.weak_direction), std::sin(c.weak_direction));
  const double per_m2 = 1.0 / (o.constraint_sigma_xy * o.constraint_sigma_xy);
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  information.topLeftCorner<2, 2>() =
      per_m2 * (Eigen::Matrix2d::Identity() - (1.0 - ratio) * weak * weak.transpose());
  information(2, 2) = 1.0 / (o.constraint_sigma_theta * o.constraint_sigma_theta);
  return information;
}

namespace {

// Every accepted candidate of an accepted pair, as a constraint.
void collectConstraints(const FloorMatcherOptions& o, MatchResult* result) {
  result->constraints.clear();
  for (const auto& p : result->pairs) {
    if (!p.accepted) continue;
    for (const auto& c : p.candidates) {
      if (c.status != CandidateStatus::kAccepted) continue;
      InterFloorConstraint ic;
      ic.reference_graph_id = c.reference_graph_id;
      ic.reference_node_id = c.reference_node_id;
      ic.graph_id = c.graph_id;
      ic.node_id = c.node_id;
      ic.measurement = c.measurement;
      ic.dz = c.dz;
      ic.information = constraintInformation(c, o);
      ic.likelihood = c.likelihood;
      ic.first_index = c.first_index;
      ic.last_index = c.last_index;
      result->constraints.push_back(ic);
    }
  }
}

}  // namespace

// Two graphs of one floor id that the pass placed through other graphs (each aligned to a
// third floor) were never checked against each other by sameFloorContradiction: a young
// graph fitted a few rooms along another floor's periodic row is. When the placement they
// imply contradicts, one of them is wrong and nothing says which: both graphs' pairs (and
// pairs that took one of them as their reference) are withdrawn from the pass. Returns
// whether any was.
bool rejectContradictedPlacements(const std::vector<floor::FloorGraph>& graphs,
                                  const std::vector<PreparedFloor>& prepared,
                                  const FloorMatcherOptions& o, MatchResult* result) {
  if (o.same_floor_see_through >= 1.0) return false;
  const GraphPlacement placement = placeGraphs(graphs, *result);
  std::set<std::pair<int, int>> paired;  // accepted pairs, checked when accepted
  for (const auto& p : result->pairs)
    if (p.accepted) {
      paired.insert({p.reference_graph_id, p.graph_id});
      paired.insert({p.graph_id, p.reference_graph_id});
    }
  std::map<int, std::string> contradicted;  // graph id -> why
  for (std::size_t a = 0; a < graphs.size(); ++a)
    for (std::size_t b = a + 1; b < graphs.size(); ++b) {
      const int id_a = graphs[a].graph_id, id_b = graphs[b].graph_id;
      if (graphs[a].floor_id != graphs[b].floor_id || !placement.joins(id_a, id_b) ||
          paired.count({id_a, id_b}))
        continue;
      const Pose2 b_in_a = placement.frame.at(id_a).inverse() * placement.frame.at(id_b);
      const std::string why = sameFloorContradiction(prepared[a], prepared[b], b_in_a, o);
      if (why.empty()) continue;
      contradicted.emplace(id_a, why);
      contradicted.emplace(id_b, why);
    }
  if (contradicted.empty()) return false;
  for (auto& p : result->pairs) {
    if (!p.accepted) continue;
    auto it = contradicted.find(p.graph_id);
    if (it == contradicted.end()) it = contradicted.find(p.reference_graph_id);
    if (it == contradicted.end()) continue;
    withdrawAsContradicted(p.reason + "; withdrawn: where the pass places them, " + it->second,
                           "its graph's placement is contradicted by another graph of its floor",
                           &p);
  }
  return true;
}

std::string floorChangeAtOdds(const floor::TransitLink& link, const floor::FloorNode& from,
                              const Pose2& from_frame, const floor::FloorNode& to,
                              const Pose2& to_frame, const FloorChangeLimits& limits) {
  const Pose2 a = from_frame * from.pose, b = to_frame * to.pose;
  const double apart = (a.translation() - b.translation()).norm();
  const double turn_off = std::abs(
      geometry::angleDiff(a.between(b).theta(), from.odometry.between(to.odometry).theta()));
  std::ostringstream why;
  why << std::fixed << std::setprecision(1) << "puts the floor change from graph "
      << link.from_graph << " (node " << link.from_node << ") to graph " << link.to_graph
      << " (node " << link.to_node << ") ";
  if (limits.radius > 0.0 && apart > limits.radius)
    why << apart << " m apart";
  else if (limits.heading > 0.0 && turn_off > limits.heading)
    why << "turned " << turn_off * 180.0 / M_PI << " deg from the robot's odometry";
  else
    return "";
  return why.str();
}

std::string floorChangeContradiction(const std::vector<floor::FloorGraph>& graphs,
                                     const std::vector<floor::TransitLink>& links, int graph_id,
                                     const Pose2& placed, const std::map<int, Pose2>& placed_graphs,
                                     const FloorMatcherOptions& o) {
  if (o.floor_change.off()) return "";
  auto node = [&](int graph, int id) -> const floor::FloorNode* {
    for (const auto& g : graphs)
      if (g.graph_id == graph) return g.findNode(id);
    return nullptr;
  };
  for (const floor::TransitLink& link : links) {
    if (link.from_graph != graph_id && link.to_graph != graph_id) continue;
    const int other = link.from_graph == graph_id ? link.to_graph : link.from_graph;
    const auto at = placed_graphs.find(other);
    if (other == graph_id || at == placed_graphs.end()) continue;
    const floor::FloorNode* from = node(link.from_graph, link.from_node);
    const floor::FloorNode* to = node(link.to_graph, link.to_node);
    if (!from || !to) continue;
    const std::string why =
        floorChangeAtOdds(link, *from, link.from_graph == graph_id ? placed : at->second, *to,
                          link.to_graph == graph_id ? placed : at->second, o.floor_change);
    if (!why.empty()) return "it " + why;
  }
  return "";
}

MatchResult matchFloors(const std::vector<floor::FloorGraph>& graphs,
                        const FloorMatcherOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  MatchResult result;
  const int n = static_cast<int>(graphs.size());
  if (n == 0) return result;
  std::vector<PreparedFloor> prepared(graphs.size());
  parallelFor(n, o.threads, [&](int i) { prepared[i] = prepareFloor(graphs[i], o); });

  result.floors.resize(graphs.size());
  for (int i = 0; i < n; ++i) {
    result.floors[i].graph_id = graphs[i].graph_id;
    result.floors[i].structure = prepared[i].structure;
    result.floors[i].l_min = prepared[i].l_min;
  }
  if (o.self_check) {
    parallelFor(n, o.threads, [&](int i) {
      result.floors[i] = checkSelfSimilarity(
          prepared[i], o, mixSeed(o.seed, 0x5E1F, static_cast<std::uint64_t>(graphs[i].graph_id)));
    });
  }
  // Reference: the floor with the most structure (occupied cells), ties by graph id;
  // self-similar floors take no part, or, with match_self_similar, come last and are
  // matched through the sequences that tell them from their twin.
  std::vector<int> order;
  for (int i = 0; i < n; ++i) {
    if (!result.floors[i].self_similar) continue;
    if (o.match_self_similar) {
      prepared[i].twin = result.floors[i].other;
      continue;
    }
    PairResult skipped;
    skipped.graph_id = graphs[i].graph_id;
    skipped.reference_graph_id = graphs[i].graph_id;
    skipped.ambiguous = true;
    skipped.reason = common::str("self-similar floor: ", result.floors[i].elsewhere,
                                 " of its own sequences agree on another alignment, ",
                                 result.floors[i].at_identity, " on the identity");
    result.pairs.push_back(std::move(skipped));
  }
  for (int i = 0; i < n; ++i)
    if (!result.floors[i].self_similar || o.match_self_similar) order.push_back(i);
  if (order.size() < 2) {
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    if (result.floors[a].self_similar != result.floors[b].self_similar) return !result.floors[a].self_similar;
    if (prepared[a].structure != prepared[b].structure)
      return prepared[a].structure > prepared[b].structure;
    return graphs[a].graph_id < graphs[b].graph_id;
  });
  const int ref = order.front();
  result.reference_graph_id = graphs[ref].graph_id;
  auto seedFor = [&](int r, int i) {
    return mixSeed(o.seed, static_cast<std::uint64_t>(graphs[r].graph_id),
                   static_cast<std::uint64_t>(graphs[i].graph_id));
  };

  // A candidate, and an accepted pair, whose placement contradicts a robot's floor change
  // to or from a graph already placed (floorChangeContradiction) is refuted; the graph
  // tries the others.
  const std::vector<floor::TransitLink> links = floor::transitLinks(graphs);
  auto byGraphId = [&](const std::map<int, Pose2>& by_index) {
    std::map<int, Pose2> out;
    for (const auto& [index, frame] : by_index) out[graphs[index].graph_id] = frame;
    return out;
  };
  // Graph i placed by an alignment into r's frame, r placed by `placed` (by index).
  auto floorChangeCheck = [&](int i, int r, const std::map<int, Pose2>& placed) -> AlignmentCheck {
    if (o.floor_change.off()) return {};
    const auto at = placed.find(r);
    const Pose2 r_frame = at == placed.end() ? Pose2() : at->second;
    const std::map<int, Pose2> placed_graphs =
        at == placed.end() ? std::map<int, Pose2>{{graphs[r].graph_id, Pose2()}}
                           : byGraphId(placed);
    const int id = graphs[i].graph_id;
    return [&graphs, &links, &o, id, r_frame, placed_graphs](const Pose2& alignment) {
      return floorChangeContradiction(graphs, links, id, r_frame * alignment, placed_graphs, o);
    };
  };
  auto rejectAtOddsWithFloorChanges = [&](PairResult* p, const AlignmentCheck& check) {
    if (!p->accepted || !check) return;
    const std::string why = check(p->alignment);
    if (why.empty()) return;
    takeBack("its set's placement contradicts a robot's floor change: " + why, p);
    p->reason += "; rejected: " + why;
  };

  std::vector<int> others(order.begin() + 1, order.end());
  std::vector<PairResult> first(others.size());
  const std::map<int, Pose2> reference_only{{ref, Pose2()}};
  parallelFor(static_cast<int>(others.size()), o.threads, [&](int j) {
    const AlignmentCheck check = floorChangeCheck(others[j], ref, reference_only);
    first[j] = matchPair(prepared[ref], prepared[others[j]], o, seedFor(ref, others[j]), check);
    rejectAtOddsWithFloorChanges(&first[j], check);
  });
  // A floor that failed for lack of evidence tries the other floors, those of the same
  // floor id (another robot's graph of the same floor) first, then by structure. One
  // that failed as ambiguous tries only graphs already aligned to the reference (its own
  // floor id first), and a retry is then accepted only if, composed with that graph's accepted
  // alignment to the reference, it agrees with one of the two ambiguous sets: two independent paths
  // must agree.
  std::map<int, Pose2> to_reference;  // accepted alignments into the reference's frame
  to_reference[ref] = Pose2();
  std::vector<int> failed;
  std::map<int, const PairResult*> primary;
  for (std::size_t j = 0; j < others.size(); ++j) {
    if (first[j].accepted) to_reference[others[j]] = first[j].alignment;
    if (!first[j].accepted) failed.push_back(others[j]);
  }
  for (std::size_t j = 0; j < others.size(); ++j) primary[others[j]] = &first[j];
  std::vector<std::vector<PairResult>> retries(failed.size());
  parallelFor(static_cast<int>(failed.size()), o.threads, [&](int j) {
    const int i = failed[j];
    const PairResult& before = *primary.at(i);
    // A graph that another graph of its floor contradicts where its scans fit best is
    // locally periodic (a young graph in a row of rooms): a map of another floor, whose
    // walls cannot be checked so, would place it as wrongly. It waits for more of itself.
    if (before.contradicted) return;
    std::vector<int> refs;
    for (int r : order)
      if (r != ref && r != i && graphs[r].floor_id == graphs[i].floor_id) refs.push_back(r);
    for (int r : order)
      if (r != ref && r != i && graphs[r].floor_id != graphs[i].floor_id) refs.push_back(r);
    for (int r : refs) {
      if (before.ambiguous && !to_reference.count(r)) continue;
      const AlignmentCheck check = floorChangeCheck(i, r, to_reference);
      PairResult p = matchPair(prepared[r], prepared[i], o, seedFor(r, i), check);
      if (p.accepted && before.ambiguous) {
        Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
        for (const auto& n : graphs[i].nodes) centroid += n.pose.translation();
        centroid /= static_cast<double>(graphs[i].nodes.size());
        const Pose2 at(centroid.x(), centroid.y(), 0.0);
        const Pose2 composed = to_reference.at(r) * p.alignment;
        bool agreed = false;
        for (const Pose2& a : before.set_alignments)
          agreed = agreed || agrees(composed, a, at, o.ransac_translation_tolerance,
                                    o.ransac_rotation_tolerance);
        if (!agreed) {
          p.accepted = false;
          p.reason +=
              "; rejected: disagrees with both sets of the ambiguous match against the reference";
          for (auto& c : p.candidates)
            if (c.status == CandidateStatus::kAccepted) {
              c.status = CandidateStatus::kAmbiguous;
              c.reason = "retry of an ambiguous floor not confirmed through the reference";
            }
        } else {
          p.reason += "; confirmed through the reference";
        }
      }
      rejectAtOddsWithFloorChanges(&p, check);
      const bool combine =
          !p.accepted && !p.ambiguous && !before.ambiguous && to_reference.count(r) && r != ref;
      retries[j].push_back(std::move(p));
      if (combine) {
        // Together, the two pairs may have enough (see combineThroughAligned).
        PairResult both =
            combineThroughAligned(before, retries[j].back(), to_reference.at(r), prepared[ref],
                                  prepared[r], prepared[i], o, seedFor(r, i) ^ 0xC0B1ULL);
        rejectAtOddsWithFloorChanges(&both, floorChangeCheck(i, ref, to_reference));
        retries[j].push_back(std::move(both));
      }
      if (retries[j].back().accepted || retries[j].back().contradicted) break;
    }
  });
  for (auto& p : first) result.pairs.push_back(std::move(p));
  for (auto& list : retries)
    for (auto& p : list) result.pairs.push_back(std::move(p));

  for (const auto& p : result.pairs) result.beam_evaluations += p.beam_evaluations;
  collectConstraints(o, &result);
  if (rejectContradictedPlacements(graphs, prepared, o, &result)) collectConstraints(o, &result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void printMatchReport(std::ostream& out, const MatchResult& result) {
  for (const auto& f : result.floors)
    out << "graph " << f.graph_id << ": structure " << f.structure << " cells, l_min " << f.l_min
        << ", own sequences at identity " << f.at_identity << ", elsewhere " << f.elsewhere
        << (f.fit_elsewhere >= 0.0
                ? common::str(" at (", f.other.x(), " m, ", f.other.y(), " m, ",
                              f.other.theta() * 180.0 / M_PI, " deg): whole-floor fit ", f.fit_identity,
                              " vs ", f.fit_elsewhere, "; at the identity, ", f.refuted,
                              " fit worse placed by it")
                : std::string())
        << (f.self_similar ? "  SELF-SIMILAR" : "") << "\n";
  out << "reference floor graph: " << result.reference_graph_id << "\n";
  for (const auto& p : result.pairs) {
    out << "graph " << p.graph_id << " in reference " << p.reference_graph_id << ": " << p.reason
        << " (" << p.sequences << " filters, " << p.not_converged << " not converged, "
        << p.wall_rechecks << " wall rechecks, l_min "
        << std::setprecision(4) << p.l_min << ", " << std::setprecision(3) << p.seconds << " s)\n";
    if (p.accepted) out << "  alignment (graph frame in reference frame): " << p.alignment << "\n";
    for (const auto& c : p.candidates) {
      out << "  " << (c.reversed ? "ref scans " : "scans ") << (c.backwards ? "<" : "")
          << c.first_index << ".." << c.last_index << " node " << c.node_id << " -> ref node "
          << c.reference_node_id << "  l_t " << std::setprecision(4) << c.likelihood << "  fit "
          << std::setprecision(3) << c.fit
          << (c.see_through >= 0.0 ? common::str("  through ", c.see_through) : std::string())
          << (c.information_ratio >= 0.0 ? common::str("  ratio ", c.information_ratio) : std::string())
          << "  particles " << c.particles << "  alignment " << c.alignment << "  c "
          << c.measurement << " dz " << c.dz << "  " << candidateStatusName(c.status);
      if (!c.reason.empty()) out << " (" << c.reason << ")";
      out << "\n";
    }
  }
  out << result.constraints.size() << " constraints accepted; " << result.beam_evaluations
      << " particle-beam evaluations in " << result.seconds << " s\n";
}

}  // namespace storey::matching
