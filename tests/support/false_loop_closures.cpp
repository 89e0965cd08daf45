#include "false_loop_closures.h"

#include <cmath>
#include <random>
#include <vector>

namespace storey::test {

std::set<std::size_t> addFalseLoopClosures(graph::PoseGraph* graph, double fraction,
                                           unsigned seed) {
  using graph::Edge;
  using graph::EdgeKind;
  std::vector<std::size_t> loops;
  for (std::size_t e = 0; e < graph->numEdges(); ++e) {
    if (graph->edges()[e].kind == EdgeKind::kLoopClosure) loops.push_back(e);
  }
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> node(0, graph->numNodes() - 1);
  std::uniform_int_distribution<std::size_t> pick(0, loops.size() - 1);
  std::uniform_real_distribution<double> pos(-5, 5), ang(-M_PI, M_PI);
  std::set<std::size_t> added;
  const std::size_t count = static_cast<std::size_t>(fraction * loops.size() + 0.5);
  while (added.size() < count) {
    const std::size_t a = node(rng), b = node(rng);
    if (a == b) continue;
    Edge e;
    e.from = graph->nodes()[a].id;
    e.to = graph->nodes()[b].id;
    e.measurement = geometry::Pose2(pos(rng), pos(rng), ang(rng));
    e.information = graph->edges()[loops[pick(rng)]].information;
    e.kind = EdgeKind::kLoopClosure;
    added.insert(graph->addEdge(e));
  }
  return added;
}

}  // namespace storey::test
