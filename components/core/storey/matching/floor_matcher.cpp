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
#include "storey/matching/floor_matcher_internal.h"
#include "storey/matching/retraction.h"

namespace storey::matching {

using namespace detail;  // NOLINT(google-build-using-namespace): the stages' shared helpers

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
    if (result.floors[a].self_similar != result.floors[b].self_similar)
      return !result.floors[a].self_similar;
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

}  // namespace storey::matching
