// When a live matcher matches again as floor graphs grow, and the graphs such a pass sees.
// The floor_matcher component starts its passes by `grewEnoughToMatch`; `storey match
// --growth-passes` replays a finished run's graphs with the same trigger.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"

namespace storey::matching {

struct GrowthTrigger {
  // graphs smaller than this are not matched yet
  int min_nodes = shipped::floor_matcher::min_nodes;
  // a matched graph starts a pass once it has this many more nodes
  int min_new_nodes = shipped::floor_matcher::min_new_nodes;
  // ...and this fraction more than when it was last matched
  double min_growth = shipped::floor_matcher::min_growth;
};

// Whether a graph of `nodes` nodes starts a pass; `matched_before`: its size at its last
// pass, or null when it has not been matched.
bool grewEnoughToMatch(std::size_t nodes, const std::size_t* matched_before, const GrowthTrigger& trigger);

// The graphs as they stood at `until`: each graph's nodes stamped no later and the edges
// between them, poses the final ones; graphs with fewer than `min_nodes` are left out.
std::vector<floor::FloorGraph> graphsUntil(const std::vector<floor::FloorGraph>& graphs, double until,
                                           std::size_t min_nodes);

// The first and last node stamps of all graphs (+inf, -inf when they have no node).
std::pair<double, double> nodeStampSpan(const std::vector<floor::FloorGraph>& graphs);

// The stamps at which a matcher with `trigger` starts passes as the graphs' nodes arrive in
// stamp order (each pass instant: a live matcher busy with one pass starts fewer), and the
// last stamp (the pass on the whole graphs, as a flush).
std::vector<double> growthPassTimes(const std::vector<floor::FloorGraph>& graphs, const GrowthTrigger& trigger);

}  // namespace storey::matching
