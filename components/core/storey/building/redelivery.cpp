#include "storey/building/redelivery.h"

#include <algorithm>

namespace storey::building {

void RedeliveryFilter::noteAccepted(const BuildingGraph& building, const JournalRecord& record) {
  if (const auto* d = std::get_if<FloorGraphDelta>(&record)) {
    auto [it, inserted] = last_sequence_.emplace(d->graph_id, d->sequence);
    if (!inserted) it->second = std::max(it->second, d->sequence);
  } else if (const auto* r = std::get_if<ConstraintRetraction>(&record)) {
    for (const auto& c : building.constraints())
      if (r->retracts(c)) retracted_.insert(encodeRecord(JournalRecord(c)));
  }
}

bool RedeliveryFilter::isRedelivery(const BuildingGraph& building,
                                    const JournalRecord& record) const {
  if (const auto* d = std::get_if<FloorGraphDelta>(&record)) {
    const auto last = last_sequence_.find(d->graph_id);
    if (last == last_sequence_.end() || d->sequence > last->second) return false;
    const auto graph = building.floorGraphs().find(d->graph_id);
    if (graph == building.floorGraphs().end() || graph->second.robot != d->robot) return false;
    const floor::FloorGraph& g = graph->second;
    for (const auto& node : d->new_nodes) {
      const floor::FloorNode* held = g.findNode(node.id);
      if (!held || held->stamp != node.stamp) return false;
    }
    for (const auto& edge : d->new_edges) {
      const bool held = std::any_of(g.edges.begin(), g.edges.end(), [&](const floor::FloorEdge& e) {
        return e.from == edge.from && e.to == edge.to && e.kind == edge.kind;
      });
      if (!held) return false;
    }
    return true;
  }
  if (std::holds_alternative<InterGraphConstraint>(record))
    return retracted_.count(encodeRecord(record)) > 0;
  return false;
}

}  // namespace storey::building
