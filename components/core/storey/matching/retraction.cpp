#include "storey/matching/retraction.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <iomanip>
#include <map>
#include <queue>
#include <set>
#include <sstream>

#include "storey/matching/constraint_judgement.h"

namespace storey::matching {

using geometry::Pose2;

RetractionOptions readRetractionOptions(const common::ConfigNode& node) {
  RetractionOptions o;
  o.enabled = node.get<bool>("enabled", o.enabled);
  o.translation = node.getDouble("translation", o.translation, 0.0, 1000.0);
  o.rotation = node.getDouble("rotation", o.rotation, 0.0, M_PI);
  o.weak_sigmas = node.getDouble("weak_sigmas", o.weak_sigmas, 0.0, 100.0);
  o.confirm_growth = node.getDouble("confirm_growth", o.confirm_growth, 0.0, 100.0);
  o.confirm_both_sides = node.get<bool>("confirm_both_sides", o.confirm_both_sides);
  // The matcher's and the growth pass's floor-change checks share one setting; a file that
  // still sets the growth pass's own copies is told where they went.
  for (const char* moved : {"confirm_transit_radius", "confirm_transit_heading"})
    if (node.has(moved))
      node.fail(moved,
                "no longer read: a growth pass checks floor changes against the matcher's "
                "floor_change_radius and floor_change_heading (floor_matcher: section)");
  node.finish();
  return o;
}

namespace {

const floor::FloorGraph* findGraph(const std::vector<floor::FloorGraph>& graphs, int id) {
  for (const auto& g : graphs)
    if (g.graph_id == id) return &g;
  return nullptr;
}

// Where the constraint puts graph `graph_id`'s frame in `reference_graph_id`'s frame,
// with the graphs' current node poses; false when a node is unknown.
bool impliedAlignment(const InterFloorConstraint& c, const std::vector<floor::FloorGraph>& graphs,
                      Pose2* alignment) {
  const floor::FloorGraph* reference = findGraph(graphs, c.reference_graph_id);
  const floor::FloorGraph* graph = findGraph(graphs, c.graph_id);
  if (!reference || !graph) return false;
  const floor::FloorNode* q = reference->findNode(c.reference_node_id);
  const floor::FloorNode* k = graph->findNode(c.node_id);
  if (!q || !k) return false;
  *alignment = q->pose * c.measurement * k->pose.inverse();
  return true;
}

}  // namespace

GraphPlacement placeGraphs(const std::vector<floor::FloorGraph>& graphs, const MatchResult& result) {
  // One alignment per directed pair: an accepted pair's constraints share its joint
  // alignment, so the first one stands for all.
  std::map<int, std::vector<std::pair<int, Pose2>>> links;  // graph -> (other, other in graph's frame)
  std::set<std::pair<int, int>> seen;
  for (const auto& c : result.constraints) {
    if (!seen.insert({c.graph_id, c.reference_graph_id}).second) continue;
    Pose2 t;  // c.graph_id's frame in c.reference_graph_id's frame
    if (!impliedAlignment(c, graphs, &t)) continue;
    links[c.reference_graph_id].push_back({c.graph_id, t});
    links[c.graph_id].push_back({c.reference_graph_id, t.inverse()});
  }
  GraphPlacement placement;
  for (const auto& [root, unused] : links) {
    if (placement.frame.count(root)) continue;
    placement.frame[root] = Pose2();
    placement.component[root] = root;
    std::queue<int> open;
    open.push(root);
    while (!open.empty()) {
      const int at = open.front();
      open.pop();
      for (const auto& [other, t] : links[at]) {
        if (placement.frame.count(other)) continue;
        placement.frame[other] = placement.frame[at] * t;
        placement.component[other] = root;
        open.push(other);
      }
    }
  }
  return placement;
}

bool GraphPlacement::joins(int a, int b) const {
  const auto ca = component.find(a), cb = component.find(b);
  return ca != component.end() && cb != component.end() && ca->second == cb->second;
}

int placementDisagreement(const InterFloorConstraint& c, const std::vector<floor::FloorGraph>& graphs,
                          const GraphPlacement& placement, const RetractionOptions& options, std::string* why) {
  if (!placement.joins(c.reference_graph_id, c.graph_id)) return -1;
  Pose2 was;
  if (!impliedAlignment(c, graphs, &was)) return -1;  // a node the graphs do not have
  const Pose2 now = placement.frame.at(c.reference_graph_id).inverse() * placement.frame.at(c.graph_id);
  // Compare where the two put the constrained node, in its reference node's frame (where
  // the information is): a heading difference alone moves the frames' origins by a lever
  // arm that says nothing about this constraint.
  const Pose2 q = findGraph(graphs, c.reference_graph_id)->findNode(c.reference_node_id)->pose;
  const Pose2 k = findGraph(graphs, c.graph_id)->findNode(c.node_id)->pose;
  const WrongConstraintLimits limits{options.translation, options.rotation, options.weak_sigmas};
  const ConstraintJudgement j = judgeConstraint(q.between(now * k), c.measurement, c.information, limits);
  if (!j.wrong) return 0;
  if (why) {
    std::ostringstream out;
    out << std::fixed << std::setprecision(2) << "the new pass places node " << c.node_id << " of graph "
        << c.graph_id << " " << j.translation << " m (" << j.along_weak << " along the constraint's weak direction, sigma "
        << j.weak_sigma << ") and " << std::setprecision(1) << j.rotation * 180.0 / M_PI
        << " deg from where this constraint put it in graph " << c.reference_graph_id;
    *why = out.str();
  }
  return 1;
}

void PlacementHistory::record(const std::vector<floor::FloorGraph>& graphs, const MatchResult& result) {
  Pass pass;
  pass.placement = placeGraphs(graphs, result);
  for (const auto& g : graphs) pass.nodes[g.graph_id] = g.nodes.size();
  passes_.push_back(std::move(pass));
}

bool PlacementHistory::confirms(const InterFloorConstraint& c, const std::vector<floor::FloorGraph>& graphs,
                                const RetractionOptions& options) const {
  const floor::FloorGraph* reference = findGraph(graphs, c.reference_graph_id);
  const floor::FloorGraph* graph = findGraph(graphs, c.graph_id);
  if (!reference || !graph) return false;
  auto grown = [&](const Pass& pass, const floor::FloorGraph& g) {
    return static_cast<double>(pass.nodes.at(g.graph_id)) * (1.0 + options.confirm_growth) <=
           static_cast<double>(g.nodes.size());
  };
  for (auto pass = passes_.rbegin(); pass != passes_.rend(); ++pass) {
    if (!pass->placement.joins(c.reference_graph_id, c.graph_id)) continue;
    if (!grown(*pass, *reference) && !grown(*pass, *graph)) continue;
    return placementDisagreement(c, graphs, pass->placement, options) == 0;
  }
  return false;
}

bool pairSeenFromBothSides(const InterFloorConstraint& c, const MatchResult& result) {
  bool forward = false, reversed = false;
  for (const auto& p : result.pairs) {
    if (p.graph_id != c.graph_id || p.reference_graph_id != c.reference_graph_id) continue;
    for (const auto& cand : p.candidates)
      if (cand.status == CandidateStatus::kAccepted) (cand.reversed ? reversed : forward) = true;
  }
  return forward && reversed;
}

GrowthPassConfirmation::GrowthPassConfirmation(const std::vector<floor::FloorGraph>& graphs,
                                               const MatchResult& result,
                                               const PlacementHistory& history,
                                               const RetractionOptions& options,
                                               const FloorChangeLimits& floor_change)
    : graphs_(graphs), result_(result), history_(history), options_(options) {
  if (floor_change.off()) return;
  const GraphPlacement placement = placeGraphs(graphs, result);
  for (const floor::TransitLink& link : floor::transitLinks(graphs)) {
    if (!placement.joins(link.from_graph, link.to_graph)) continue;
    const floor::FloorNode* from = findGraph(graphs, link.from_graph)->findNode(link.from_node);
    const floor::FloorNode* to = findGraph(graphs, link.to_graph)->findNode(link.to_node);
    const std::string at_odds =
        floorChangeAtOdds(link, *from, placement.frame.at(link.from_graph), *to,
                          placement.frame.at(link.to_graph), floor_change);
    if (at_odds.empty()) continue;
    const std::string why = "the pass " + at_odds;
    at_odds_.emplace(link.from_graph, why);
    at_odds_.emplace(link.to_graph, why);
  }
}

bool GrowthPassConfirmation::placedAtOdds(const InterFloorConstraint& c) const {
  return at_odds_.count(c.graph_id) || at_odds_.count(c.reference_graph_id);
}

bool GrowthPassConfirmation::mayRetract(const InterFloorConstraint& c) const {
  return !placedAtOdds(c);
}

bool GrowthPassConfirmation::confirms(const InterFloorConstraint& c) const {
  if (options_.confirm_both_sides && !pairSeenFromBothSides(c, result_)) return false;
  if (placedAtOdds(c)) return false;
  return history_.confirms(c, graphs_, options_);
}

namespace {

// Why the new pass found graph `id` ambiguous and aligned it nowhere ("" when it did not).
std::string ambiguity(int id, const MatchResult& result, const GraphPlacement& placement) {
  if (placement.frame.count(id)) return "";
  for (const auto& f : result.floors)
    if (f.graph_id == id && f.self_similar) return "floor graph " + std::to_string(id) + " is now self-similar";
  for (const auto& p : result.pairs)
    if (p.graph_id == id && p.ambiguous)
      return "floor graph " + std::to_string(id) + " is now ambiguous against graph " +
             std::to_string(p.reference_graph_id);
  return "";
}

}  // namespace

std::vector<Retraction> constraintsToRetract(const std::vector<InterFloorConstraint>& published,
                                             const std::vector<floor::FloorGraph>& graphs,
                                             const MatchResult& result,
                                             const RetractionOptions& options,
                                             const GrowthPassConfirmation* growth) {
  std::vector<Retraction> out;
  if (!options.enabled) return out;
  const GraphPlacement placement = placeGraphs(graphs, result);
  for (std::size_t i = 0; i < published.size(); ++i) {
    const InterFloorConstraint& c = published[i];
    if (growth && !growth->mayRetract(c)) continue;
    if (placement.joins(c.reference_graph_id, c.graph_id)) {
      std::string disagreement;
      if (placementDisagreement(c, graphs, placement, options, &disagreement) == 1)
        out.push_back({i, disagreement});
      continue;
    }
    std::string why = ambiguity(c.graph_id, result, placement);
    if (why.empty()) why = ambiguity(c.reference_graph_id, result, placement);
    if (!why.empty()) out.push_back({i, why});
  }
  return out;
}

}  // namespace storey::matching
