#include "storey/matching/growth_passes.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>
#include <utility>

namespace storey::matching {

bool grewEnoughToMatch(std::size_t nodes, const std::size_t* matched_before, const GrowthTrigger& trigger) {
  if (nodes < static_cast<std::size_t>(trigger.min_nodes)) return false;
  if (!matched_before) return true;
  return nodes >= *matched_before + static_cast<std::size_t>(trigger.min_new_nodes) &&
         static_cast<double>(nodes) >= (1.0 + trigger.min_growth) * static_cast<double>(*matched_before);
}

std::vector<floor::FloorGraph> graphsUntil(const std::vector<floor::FloorGraph>& graphs, double until,
                                           std::size_t min_nodes) {
  std::vector<floor::FloorGraph> out;
  for (const auto& g : graphs) {
    floor::FloorGraph prefix = g;
    prefix.nodes.clear();
    prefix.edges.clear();
    std::set<int> kept;
    for (const auto& n : g.nodes)
      if (n.stamp <= until) {
        prefix.nodes.push_back(n);
        kept.insert(n.id);
      }
    for (const auto& e : g.edges)
      if (kept.count(e.from) && kept.count(e.to)) prefix.edges.push_back(e);
    if (prefix.nodes.size() >= min_nodes) out.push_back(std::move(prefix));
  }
  return out;
}

std::pair<double, double> nodeStampSpan(const std::vector<floor::FloorGraph>& graphs) {
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (const auto& g : graphs)
    for (const auto& n : g.nodes) {
      first = std::min(first, n.stamp);
      last = std::max(last, n.stamp);
    }
  return {first, last};
}

std::vector<double> growthPassTimes(const std::vector<floor::FloorGraph>& graphs, const GrowthTrigger& trigger) {
  std::vector<std::pair<double, int>> stamps;  // (stamp, graph id)
  for (const auto& g : graphs)
    for (const auto& n : g.nodes) stamps.push_back({n.stamp, g.graph_id});
  std::sort(stamps.begin(), stamps.end());
  std::map<int, std::size_t> nodes, matched;
  std::vector<double> times;
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    ++nodes[stamps[i].second];
    if (i + 1 < stamps.size() && stamps[i + 1].first == stamps[i].first) continue;  // the stamp's other nodes first
    bool start = false;
    for (const auto& [id, now] : nodes) {
      const auto before = matched.find(id);
      start = start || grewEnoughToMatch(now, before == matched.end() ? nullptr : &before->second, trigger);
    }
    if (!start) continue;
    times.push_back(stamps[i].first);
    // A pass records the size of every graph it matched (as the component does).
    for (const auto& [id, now] : nodes)
      if (now >= static_cast<std::size_t>(trigger.min_nodes)) matched[id] = now;
  }
  if (!stamps.empty() && (times.empty() || times.back() < stamps.back().first)) times.push_back(stamps.back().first);
  return times;
}

}  // namespace storey::matching
