// When a live matcher matches again (storey::matching::grewEnoughToMatch) and the replay of
// a finished run's growth (growthPassTimes, graphsUntil).
#include <gtest/gtest.h>

#include "storey/matching/growth_passes.h"

namespace storey::matching {
namespace {

// `count` nodes, one a second from `first_stamp`, with an edge between each two in a row.
floor::FloorGraph graphStamped(int id, int count, double first_stamp) {
  floor::FloorGraph g;
  g.graph_id = id;
  for (int i = 0; i < count; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.stamp = first_stamp + i;
    g.nodes.push_back(n);
    if (i > 0) {
      floor::FloorEdge e;
      e.from = i - 1;
      e.to = i;
      g.edges.push_back(e);
    }
  }
  return g;
}

TEST(GrowthTrigger, ANewGraphOfMinNodesOrAGraphGrownByBothLimits) {
  const GrowthTrigger t;  // 10 nodes; 20 more and 20 % more
  EXPECT_FALSE(grewEnoughToMatch(9, nullptr, t));
  EXPECT_TRUE(grewEnoughToMatch(10, nullptr, t));
  const std::size_t ten = 10, two_hundred = 200;
  EXPECT_FALSE(grewEnoughToMatch(29, &ten, t));
  EXPECT_TRUE(grewEnoughToMatch(30, &ten, t));
  EXPECT_FALSE(grewEnoughToMatch(239, &two_hundred, t)) << "20 more, but not 20 % more";
  EXPECT_TRUE(grewEnoughToMatch(240, &two_hundred, t));
}

TEST(GrowthPasses, StartWhereTheTriggerWouldAndEndOnTheWholeGraphs) {
  // Graph 0 grows over stamps 0-49; graph 1 over 100-134 (the robot took the lift).
  const std::vector<floor::FloorGraph> graphs{graphStamped(0, 50, 0.0), graphStamped(1, 35, 100.0)};
  const std::vector<double> times = growthPassTimes(graphs, GrowthTrigger{});
  // Graph 0 at 10, 30 and 50 nodes; graph 1 new at 10 and at 30; then the whole graphs.
  EXPECT_EQ(times, (std::vector<double>{9.0, 29.0, 49.0, 109.0, 129.0, 134.0}));
  GrowthTrigger every_node;
  every_node.min_new_nodes = 1;
  every_node.min_growth = 0.0;
  EXPECT_EQ(growthPassTimes(graphs, every_node).size(), 41u + 26u);
  EXPECT_TRUE(growthPassTimes({}, GrowthTrigger{}).empty());
}

TEST(GrowthPasses, NodesOfOneStampArriveTogether) {
  std::vector<floor::FloorGraph> graphs{graphStamped(0, 30, 0.0)};
  for (auto& n : graphs[0].nodes) n.stamp = 5.0;  // all at once
  EXPECT_EQ(growthPassTimes(graphs, GrowthTrigger{}), std::vector<double>{5.0});
}

TEST(GrowthPasses, TheGraphsAsTheyStoodKeepTheirEarlierNodesAndEdges) {
  const std::vector<floor::FloorGraph> graphs{graphStamped(0, 50, 0.0), graphStamped(1, 35, 100.0)};
  const auto at_20 = graphsUntil(graphs, 19.5, 10);
  ASSERT_EQ(at_20.size(), 1u) << "graph 1 has no node yet";
  EXPECT_EQ(at_20[0].nodes.size(), 20u);
  EXPECT_EQ(at_20[0].edges.size(), 19u);
  const auto at_105 = graphsUntil(graphs, 105.0, 10);
  EXPECT_EQ(at_105.size(), 1u) << "graph 1's 6 nodes are fewer than 10";
  EXPECT_EQ(graphsUntil(graphs, 105.0, 5).size(), 2u);
}

TEST(GrowthPasses, TheStampSpanCoversEveryGraphsNodes) {
  const std::vector<floor::FloorGraph> graphs{graphStamped(0, 50, 0.0), graphStamped(1, 35, 100.0)};
  EXPECT_EQ(nodeStampSpan(graphs), std::make_pair(0.0, 134.0));
  EXPECT_GT(nodeStampSpan({}).first, nodeStampSpan({}).second) << "no node: an empty span";
}

}  // namespace
}  // namespace storey::matching
