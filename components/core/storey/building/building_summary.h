// What a person wants to know first about a mapped building: how many floors and robots,
// whether the inter-floor constraints placed every floor graph, and which floors to look
// at when they did not (report.html's summary).
#pragma once

#include <string>
#include <vector>

#include "storey/building/building_graph.h"

namespace storey::building {

struct BuildingSummary {
  int floors = 0;          // distinct floor ids
  int robots = 0;          // distinct robots
  int graphs = 0;          // floor graphs
  int aligned_graphs = 0;  // joined to the reference by inter-floor constraints
  int constraints = 0;
  // One line per floor graph the constraints did not place: its floor, robot and how it
  // was placed instead; empty when every graph is aligned.
  std::vector<std::string> warnings;
  // Floor ids with a graph that is not aligned, ascending.
  std::vector<int> floors_to_check;
};

BuildingSummary summarizeBuilding(const BuildingGraph& graph, const BuildingSolution& solution);

}  // namespace storey::building
