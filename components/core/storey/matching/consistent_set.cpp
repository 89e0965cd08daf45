// The consistent-set stage: RANSAC over gated candidates, rival sets, twins and bent
// floors, and the accepted set's joint alignment and constraints (decideConsistentSet).
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

namespace detail {

void takeBack(const std::string& candidate_reason, PairResult* p) {
  p->accepted = false;
  for (auto& c : p->candidates)
    if (c.status == CandidateStatus::kAccepted) {
      c.status = CandidateStatus::kContradicted;
      c.reason = candidate_reason;
    }
}

void withdrawAsContradicted(const std::string& pair_reason, const std::string& candidate_reason,
                            PairResult* p) {
  takeBack(candidate_reason, p);
  p->contradicted = true;
  p->reason = pair_reason;
}

std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = seed ^ (a * 0x9E3779B97F4A7C15ULL) ^ (b * 0xC2B2AE3D27D4EB4FULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

bool passedGate(CandidateStatus s) {
  return s != CandidateStatus::kLowLikelihood && s != CandidateStatus::kPoorFit &&
         s != CandidateStatus::kUnderconstrained;
}

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

bool agrees(const Pose2& a, const Pose2& b, const Pose2& node_pose, double tol_t, double tol_r) {
  const Pose2 pa = a * node_pose, pb = b * node_pose;
  return (pa.translation() - pb.translation()).norm() <= tol_t &&
         std::abs(normalizeAngle(pa.theta() - pb.theta())) <= tol_r;
}

Pose2 meanAlignment(const std::vector<Pose2>& poses, const std::vector<double>& weights) {
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

int scanCount(const std::vector<std::pair<int, int>>& ranges) {
  int n = 0;
  for (const auto& [first, last] : ranges) n += last - first + 1;
  return n;
}

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

std::vector<std::size_t> largestConsistentSet(const std::vector<Candidate>& cands,
                                              const std::vector<std::size_t>& pool,
                                              const floor::FloorGraph& graph,
                                              const FloorMatcherOptions& o, std::mt19937_64* rng,
                                              std::vector<std::size_t>* all) {
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

}  // namespace detail

std::vector<std::size_t> bentFloorCandidates(const std::vector<Candidate>& cands,
                                             const std::vector<std::size_t>& pool,
                                             const std::vector<std::size_t>& core,
                                             const floor::FloorGraph& graph,
                                             const FloorMatcherOptions& o) {
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
      nearest = std::min(
          nearest, (graph.nodes[cands[j].node_index].pose.translation() - pk.translation()).norm());
    if (agrees(mean, cands[i].alignment, pk,
               o.ransac_translation_tolerance + o.ransac_distortion * nearest,
               o.ransac_rotation_tolerance))
      out.push_back(i);
  }
  return out;
}

namespace detail {

bool secondSetStands(std::size_t best, std::size_t second, const FloorMatcherOptions& o,
                     const std::function<std::pair<double, double>()>& fits) {
  const bool rival_by_count =
      second >= 2 && static_cast<double>(second) >= o.ambiguity_ratio * static_cast<double>(best);
  const bool rival_by_size = static_cast<int>(second) >= o.min_constraints;
  if (!rival_by_count && !rival_by_size) return false;
  const auto [fit_best, fit_second] = fits();
  return rival_by_count ? fit_best < fit_second + o.ambiguity_fit_margin : fit_second > fit_best;
}

double weakDirectionAt(const Candidate& c, const Pose2& alignment, const Pose2& q) {
  return geometry::normalizeAngle(c.weak_direction + (c.reversed ? alignment.theta() : 0.0) -
                                  q.theta());
}

}  // namespace detail

namespace {

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
    const double at_own =
        refineAlignment(map_floor.map->field(), scans, range, o.refine_beams, 0, &own);
    for (const Pose2& twin : twins) {
      Pose2 placed = c.reversed ? twin.inverse() : twin;
      const double at_twin = refineAlignment(map_floor.map->field(), scans, range, o.refine_beams,
                                             o.refine_iterations, &placed);
      if (at_own - at_twin > o.ambiguity_fit_margin) continue;
      c.fits_twin = true;
      c.status = CandidateStatus::kAmbiguous;
      c.reason = common::str("a self-similar floor's twin alignment fits its scans about as well (",
                             at_twin, " against ", at_own, ")");
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
  std::vector<std::size_t> best =
      largestConsistentSet(result.candidates, pool, g, o, &rng, &best_all);
  const std::vector<std::size_t> bent =
      bentFloorCandidates(result.candidates, pool, best_all, g, o);
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
    const bool use_backward =
        !reversed_ranges.empty() && (!use_forward || o.joint_alignment_both_directions);
    const Pose2 mean = meanAlignment(alignments);
    Pose2 forward = mean, backward = mean;
    if (use_forward)
      forward = refinedOnScans(reference, g, ranges, o, mean);  // g_i's scans in g_ref's map
    if (use_backward)                                           // g_ref's scans in g_i's map
      backward = refinedOnScans(floor_data, *reference.graph, reversed_ranges, o, mean.inverse())
                     .inverse();
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
      const Pose2 placed =
          o.local_constraint_translation
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

}  // namespace storey::matching
