// False loop closures for the optimiser's outlier tests and benchmark.
#pragma once

#include <cstddef>
#include <set>

#include "storey/graph/pose_graph.h"

namespace storey::test {

// Adds seeded random false loop closures (fraction × the graph's true loop-closure count)
// between random pose pairs, each with the information of a randomly picked true loop
// closure, so the optimiser cannot tell them apart by their weight. Returns their edge
// indices.
std::set<std::size_t> addFalseLoopClosures(graph::PoseGraph* graph, double fraction, unsigned seed);

}  // namespace storey::test
