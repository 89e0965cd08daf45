#include "storey/floor_matcher/floor_matcher_component.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

#include "storey/matching/simulated_floors.h"
#include "storey/runtime/context.h"
#include "storey/runtime/graph_conversions.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/subscription.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::floor_matcher {
namespace {

using FloorGraphPublisher = runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                                               storey_msgs::msg::FloorGraphUpdatePubSubType>;

runtime::ContextOptions onDomain(int domain) {
  runtime::ContextOptions options;
  options.domain_id = domain;
  return options;
}

// A floor graph as the mapper sends it, nodes [first, last) of it.
storey_msgs::msg::FloorGraphUpdate toUpdate(const floor::FloorGraph& g, std::size_t first,
                                            std::size_t last, std::uint32_t sequence) {
  storey_msgs::msg::FloorGraphUpdate u;
  u.robot(g.robot);
  u.floor_graph_id(static_cast<std::uint32_t>(g.graph_id));
  u.floor_id(g.floor_id);
  u.floor_height(g.floor_height);
  u.sequence_number(sequence);
  for (std::size_t i = first; i < last && i < g.nodes.size(); ++i)
    u.new_nodes().push_back(runtime::toMessage(g.nodes[i], static_cast<std::uint32_t>(g.graph_id)));
  return u;
}

// An active matcher component with a publisher of floor-graph updates, discovered.
struct RunningMatcher {
  RunningMatcher(runtime::Context& context, const std::string& parameters)
      : matcher(context, common::ConfigNode::loadString(parameters), "floor_matcher"),
        graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph) {
    matcher.configure();
    matcher.activate();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  }
  FloorMatcherComponent matcher;
  FloorGraphPublisher graphs;
};

matching::SimulatedFloors small2(std::uint64_t seed) {
  const auto scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/small2.yaml");
  matching::SimulatedFloorsOptions so;
  so.seed = seed;
  return matching::floorGraphsFromSimulation(sim::simulate(scenario, seed), so);
}

TEST(FloorMatcherComponent, PublishesCorrectConstraintsForTwoFloors) {
  const matching::SimulatedFloors floors = small2(5);
  ASSERT_EQ(floors.graphs.size(), 2u);
  runtime::Context context(onDomain(215));
  std::mutex mutex;
  std::vector<storey_msgs::msg::InterFloorConstraint> received;
  runtime::Subscription<storey_msgs::msg::InterFloorConstraint,
                        storey_msgs::msg::InterFloorConstraintPubSubType>
      sub(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph,
          [&](const storey_msgs::msg::InterFloorConstraint& c) {
            std::lock_guard<std::mutex> lock(mutex);
            received.push_back(c);
          });
  RunningMatcher running(context, "{min_nodes: 10, floor_matcher: {seed: 3}}");
  FloorMatcherComponent& matcher = running.matcher;
  FloorGraphPublisher& graphs = running.graphs;
  // The first graph in two updates (the second only adds nodes), then the other one.
  const auto& g0 = floors.graphs[0];
  graphs.publish(toUpdate(g0, 0, g0.nodes.size() / 2, 0));
  graphs.publish(toUpdate(g0, g0.nodes.size() / 2, g0.nodes.size(), 1));
  graphs.publish(toUpdate(floors.graphs[1], 0, floors.graphs[1].nodes.size(), 0));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline && matcher.stats().updates_accepted < 3)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(matcher.stats().updates_accepted, 3u);
  ASSERT_TRUE(matcher.flush(60.0));
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (received.size() >= matcher.stats().constraints_published) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_GE(received.size(), 3u);
  EXPECT_EQ(received.size(), matcher.stats().constraints_published);
  for (const auto& m : received) {
    matching::InterFloorConstraint c;
    c.reference_graph_id = static_cast<int>(m.from_floor_graph());
    c.reference_node_id = static_cast<int>(m.from_node());
    c.graph_id = static_cast<int>(m.to_floor_graph());
    c.node_id = static_cast<int>(m.to_node());
    c.measurement = geometry::Pose2(m.dx(), m.dy(), m.dtheta());
    const auto e = matching::judgeConstraint(c, floors);
    EXPECT_LT(e.translation, 0.3);
    EXPECT_LT(e.rotation, 2.0 * M_PI / 180.0);
    EXPECT_NEAR(std::abs(m.dz()), 3.5, 1e-9);
    EXPECT_GE(m.mean_likelihood(), m.likelihood_threshold());
    EXPECT_GE(m.ransac_support(), 3u);
    EXPECT_GT(m.information()[0], 0.0);
  }
  matcher.deactivate();
  matcher.cleanup();
}

// A one-floor building (a single log mapped with `storey map`): the pass finds nothing to
// match, and a flush must see that at once instead of waiting out its timeout (it waited
// the whole 600 s of storey map's until session 18).
TEST(FloorMatcherComponent, FlushReturnsWhenOnlyOneFloorGraphExists) {
  const matching::SimulatedFloors floors = small2(5);
  runtime::Context context(onDomain(217));
  RunningMatcher running(context, "{min_nodes: 10}");
  FloorMatcherComponent& matcher = running.matcher;
  const auto& g0 = floors.graphs[0];
  running.graphs.publish(toUpdate(g0, 0, g0.nodes.size(), 0));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline && matcher.stats().updates_accepted < 1)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_EQ(matcher.stats().updates_accepted, 1u);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(matcher.flush(120.0));
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(waited, 30.0) << "the flush waited for a pass that had ended";
  EXPECT_EQ(matcher.stats().constraints_published, 0u);
  matcher.deactivate();
  matcher.cleanup();
}

TEST(FloorMatcherComponent, BadUpdatesAreRejectedAndCounted) {
  runtime::Context context(onDomain(216));
  RunningMatcher running(context, "{}");
  FloorMatcherComponent& matcher = running.matcher;
  FloorGraphPublisher& graphs = running.graphs;
  floor::FloorGraph g;
  g.graph_id = 4;
  for (int i = 0; i < 3; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.pose = geometry::Pose2(i, 0, 0);
    n.scan.angle_min = -1.0;
    n.scan.angle_increment = 0.1;
    n.scan.range_min = 0.1;
    n.scan.range_max = 10.0;
    n.scan.ranges.assign(21, 2.0f);
    g.nodes.push_back(n);
  }
  auto bad = toUpdate(g, 0, 3, 0);
  bad.new_nodes()[1].x(std::nan(""));
  graphs.publish(bad);
  graphs.publish(toUpdate(g, 0, 3, 1));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline &&
         matcher.stats().rejected + matcher.stats().updates_accepted < 2)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(matcher.stats().rejected, 1u);
  EXPECT_EQ(matcher.stats().updates_accepted, 1u);
  EXPECT_TRUE(matcher.flush(5.0));
  EXPECT_EQ(matcher.stats().constraints_published, 0u);
}

TEST(FloorMatcherComponentOptions, UnknownKeysAreErrors) {
  EXPECT_THROW(
      readFloorMatcherComponentOptions(common::ConfigNode::loadString("{min_node: 3}", "fm.yaml")),
      common::ConfigError);
  EXPECT_THROW(readFloorMatcherComponentOptions(
                   common::ConfigNode::loadString("{floor_matcher: {filter: {beams: -1}}}", "fm.yaml")),
               common::ConfigError);
  const auto o = readFloorMatcherComponentOptions(common::ConfigNode::loadString(
      "{min_new_nodes: 7, floor_matcher: {min_constraints: 4}}", "fm.yaml"));
  EXPECT_EQ(o.min_new_nodes, 7);
  EXPECT_EQ(o.matcher.min_constraints, 4);
}

}  // namespace
}  // namespace storey::floor_matcher
