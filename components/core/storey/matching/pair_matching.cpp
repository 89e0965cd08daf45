// Matching one pair of floors: both directions and time-reversed sequences, the
// self-similarity check, evidence combined through an aligned floor, and constraint
// information.
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

PairResult matchPair(const PreparedFloor& reference, const PreparedFloor& floor_data,
                     const FloorMatcherOptions& o, std::uint64_t seed,
                     const AlignmentCheck& refuted) {
  return matchPairDirected(reference, floor_data, o, seed, o.match_both_directions, refuted);
}

namespace {

// How many of the candidates `home` (sequences of a floor localised in its own map at the
// identity) fit that map worse by more than ambiguity_fit_margin when placed by `twin`.
int refutingSequences(const PreparedFloor& floor_data, const std::vector<Candidate>& candidates,
                      const std::vector<std::size_t>& home, const Pose2& twin,
                      const FloorMatcherOptions& o) {
  int refuting = 0;
  for (std::size_t i : home) {
    const Candidate& c = candidates[i];
    const std::vector<std::pair<int, int>> range = orderedRange(c);
    Pose2 identity, placed = twin;
    const double at_home = refineAlignment(floor_data.map->field(), *floor_data.graph, range,
                                           o.refine_beams, 0, &identity);
    const double at_twin = refineAlignment(floor_data.map->field(), *floor_data.graph, range,
                                           o.refine_beams, 0, &placed);
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
    out.reason =
        common::str("with ", via_name, " (aligned): two disjoint consistent sets of ", best.size(),
                    " and ", second.size(), ", whole-floor fit ", fit_best, " vs ", fit_second);
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
      add(3,
          t_r * refinedOnScans(floor_data, r_graph, ranges[3], o, mean_in_r.inverse()).inverse());
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
  const double ratio =
      c.information_ratio < 0.0 ? 1.0 : std::clamp(c.information_ratio, kMinRatio, 1.0);
  const Eigen::Vector2d weak(std::cos(c.weak_direction), std::sin(c.weak_direction));
  const double per_m2 = 1.0 / (o.constraint_sigma_xy * o.constraint_sigma_xy);
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  information.topLeftCorner<2, 2>() =
      per_m2 * (Eigen::Matrix2d::Identity() - (1.0 - ratio) * weak * weak.transpose());
  information(2, 2) = 1.0 / (o.constraint_sigma_theta * o.constraint_sigma_theta);
  return information;
}

}  // namespace storey::matching
