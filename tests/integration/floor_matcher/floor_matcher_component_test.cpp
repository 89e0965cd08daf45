#include "storey/floor_matcher/floor_matcher_component.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "storey/eval/simulated_floors.h"
#include "storey/floor_matcher/conversions.h"
#include "storey/graph_server/graph_server.h"
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
  std::set<int> sent;
  for (std::size_t i = 0; i < last && i < g.nodes.size(); ++i) {
    sent.insert(g.nodes[i].id);
    if (i >= first)
      u.new_nodes().push_back(runtime::toMessage(g.nodes[i], static_cast<std::uint32_t>(g.graph_id)));
  }
  for (const auto& e : g.edges)  // the edges these nodes complete
    if (sent.count(e.from) && sent.count(e.to) &&
        std::any_of(g.nodes.begin() + static_cast<std::ptrdiff_t>(std::min(first, g.nodes.size())),
                    g.nodes.begin() + static_cast<std::ptrdiff_t>(std::min(last, g.nodes.size())),
                    [&](const floor::FloorNode& n) { return n.id == e.from || n.id == e.to; }))
      u.new_edges().push_back(runtime::toMessage(e));
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

eval::SimulatedFloors small2(std::uint64_t seed) {
  const auto scenario = sim::loadScenario(test::sourceDir() + "/config/buildings/small2.yaml");
  eval::SimulatedFloorsOptions so;
  so.seed = seed;
  return eval::floorGraphsFromSimulation(sim::simulate(scenario, seed), so);
}

// Every message on the constraint topic, as it arrives.
struct ReceivedConstraints {
  explicit ReceivedConstraints(runtime::Context& context)
      : subscription(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph,
                     [this](const storey_msgs::msg::InterFloorConstraint& c) {
                       std::lock_guard<std::mutex> lock(mutex);
                       messages.push_back(c);
                     }) {}
  std::mutex mutex;
  std::vector<storey_msgs::msg::InterFloorConstraint> messages;
  runtime::Subscription<storey_msgs::msg::InterFloorConstraint, storey_msgs::msg::InterFloorConstraintPubSubType>
      subscription;
};

TEST(FloorMatcherComponent, PublishesCorrectConstraintsForTwoFloors) {
  const eval::SimulatedFloors floors = small2(5);
  ASSERT_EQ(floors.graphs.size(), 2u);
  runtime::Context context(onDomain(215));
  ReceivedConstraints constraints(context);
  std::mutex& mutex = constraints.mutex;
  std::vector<storey_msgs::msg::InterFloorConstraint>& received = constraints.messages;
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
    const auto e = eval::judgeConstraint(constraintFromMessage(m), floors);
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
// match, and a flush must see that at once instead of waiting out its timeout (storey
// map's is 600 s).
TEST(FloorMatcherComponent, FlushReturnsWhenOnlyOneFloorGraphExists) {
  const eval::SimulatedFloors floors = small2(5);
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

// A node crosses DDS with its pose and the robot's raw odometry; the matcher replays
// scans with the pose it was first sent with and checks floor changes with the odometry.
TEST(FloorGraphNodeMessage, CarriesTheRawOdometryBesideThePose) {
  floor::FloorNode n;
  n.id = 7;
  n.pose = geometry::Pose2(1.0, 2.0, 0.5);
  n.first_pose = geometry::Pose2(0.9, 2.1, 0.4);  // the mapper's pose before optimising
  n.odometry = geometry::Pose2(-30.0, 12.0, -2.0);
  n.scan.angle_min = -1.0;
  n.scan.angle_increment = 0.1;
  n.scan.range_min = 0.1;
  n.scan.range_max = 10.0;
  n.scan.ranges.assign(21, 2.0f);
  auto message = runtime::toMessage(n, 3);
  const floor::FloorNode back = runtime::fromMessage(message, "update");
  EXPECT_EQ(back.odometry.vector(), n.odometry.vector());
  EXPECT_EQ(back.pose.vector(), n.pose.vector());
  EXPECT_EQ(back.first_pose.vector(), n.pose.vector()) << "sent once, with the pose it had then";
  message.odom_theta(std::nan(""));
  try {
    runtime::fromMessage(message, "update");
    ADD_FAILURE() << "a non-finite odometry heading was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("node 7.odom_theta"), std::string::npos) << e.what();
  }
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


// Polls `done` until it holds or `seconds` pass; returns its last value.
template <class Done>
bool waitUntil(Done done, double seconds = 30.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline && !done())
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return done();
}

// A matcher whose passes are scripted: pass i places graph 1 by `alignments[i]` (the last
// one for later passes), through three of its nodes, so a test decides what a later pass
// overturns, and the component's publishing and the server's handling are what is tested.
class ScriptedMatcher : public FloorMatcherComponent {
 public:
  ScriptedMatcher(runtime::Context& context, const std::string& parameters,
                  std::vector<geometry::Pose2> alignments)
      : FloorMatcherComponent(context, common::ConfigNode::loadString(parameters), "floor_matcher"),
        alignments_(std::move(alignments)) {}

 protected:
  matching::MatchResult match(const std::vector<floor::FloorGraph>& graphs,
                              const matching::FloorMatcherOptions&) override {
    const geometry::Pose2 t = alignments_[std::min(passes_++, alignments_.size() - 1)];
    const floor::FloorGraph& reference = graphs[0];
    const floor::FloorGraph& graph = graphs[1];
    matching::MatchResult r;
    r.reference_graph_id = reference.graph_id;
    for (std::size_t i : {graph.nodes.size() / 4, graph.nodes.size() / 2, graph.nodes.size() - 1}) {
      const floor::FloorNode& k = graph.nodes[i];
      const geometry::Pose2 placed = t * k.pose;
      const floor::FloorNode& q = reference.nodes[static_cast<std::size_t>(
          reference.nearestNodeIndex(placed.translation()))];
      matching::InterFloorConstraint c;
      c.reference_graph_id = reference.graph_id;
      c.reference_node_id = q.id;
      c.graph_id = graph.graph_id;
      c.node_id = k.id;
      c.measurement = q.pose.between(placed);
      c.information = Eigen::Matrix3d::Identity() * 100.0;
      r.constraints.push_back(c);
    }
    matching::PairResult p;
    p.reference_graph_id = reference.graph_id;
    p.graph_id = graph.graph_id;
    p.accepted = true;
    p.alignment = t;
    r.pairs.push_back(p);
    return r;
  }

 private:
  std::vector<geometry::Pose2> alignments_;
  std::size_t passes_ = 0;
};

// A scripted matcher whose passes take `seconds`, saying when one has started.
class SlowScriptedMatcher : public ScriptedMatcher {
 public:
  SlowScriptedMatcher(runtime::Context& context, const std::string& parameters,
                      std::vector<geometry::Pose2> alignments, double seconds)
      : ScriptedMatcher(context, parameters, std::move(alignments)), seconds_(seconds) {}
  std::atomic<bool> started{false};

 protected:
  matching::MatchResult match(const std::vector<floor::FloorGraph>& graphs,
                              const matching::FloorMatcherOptions& options) override {
    started = true;
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds_));
    return ScriptedMatcher::match(graphs, options);
  }

 private:
  double seconds_;
};

// A scripted matcher that matches at every update of a graph, active, with a publisher of
// floor-graph updates, discovered.
struct GrowingScriptedMatcher {
  GrowingScriptedMatcher(runtime::Context& context, std::vector<geometry::Pose2> alignments)
      : matcher(context,
                "{min_nodes: 10, min_new_nodes: 1, min_growth: 0.0, match_while_growing: true, "
                "match_after_idle: 0}",
                std::move(alignments)),
        graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph) {
    matcher.configure();
    matcher.activate();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  }
  ~GrowingScriptedMatcher() { matcher.deactivate(); }
  ScriptedMatcher matcher;
  FloorGraphPublisher graphs;
};

// small2 (seed 5) as two floor graphs, graph 1's true placement in graph 0's frame, and a
// wrong one a room along.
struct TwoFloors {
  eval::SimulatedFloors floors = small2(5);
  geometry::Pose2 truth = floors.frames[0].inverse() * floors.frames[1];
  geometry::Pose2 wrong = geometry::Pose2(4.0, 0.0, 0.0) * truth;
};

// Every constraint `building` holds places graph 1's node where `truth` does.
void expectHeldAtTruth(const building::BuildingGraph& building, const geometry::Pose2& truth) {
  for (const auto& c : building.constraints()) {
    const geometry::Pose2 k = building.floorGraphs().at(c.graph_to).findNode(c.node_to)->pose;
    const geometry::Pose2 q = building.floorGraphs().at(c.graph_from).findNode(c.node_from)->pose;
    EXPECT_LT(((q * c.relative).translation() - (truth * k).translation()).norm(), 1e-6);
  }
}

// Two passes over DDS to a graph server with a journal: the second, on a grown graph,
// places graph 1 elsewhere; its three earlier constraints are withdrawn (the server holds
// only the new ones, and so does a server restarted from its journal).
TEST(FloorMatcherComponent, RetractsWhatALaterPassNoLongerStandsBehind) {
  const TwoFloors two;
  ASSERT_EQ(two.floors.graphs.size(), 2u);
  const auto& g0 = two.floors.graphs[0];
  const auto& g1 = two.floors.graphs[1];
  const geometry::Pose2& truth = two.truth;
  const geometry::Pose2& wrong = two.wrong;  // one room along
  const std::string journal = test::makeTempDir() + "/journal.bin";
  const std::string server_parameters =
      "{optimize_min_period: 0.05, publish_maps: false, journal: '" + journal + "'}";
  runtime::Context context(onDomain(218));
  graph_server::GraphServer server(context, common::ConfigNode::loadString(server_parameters), "graph_server");
  server.configure();
  server.activate();
  ScriptedMatcher matcher(context, "{min_nodes: 10, match_while_growing: false, match_after_idle: 0}",
                          {wrong, truth});
  matcher.configure();
  matcher.activate();
  FloorGraphPublisher graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  graphs.publish(toUpdate(g0, 0, g0.nodes.size(), 0));
  graphs.publish(toUpdate(g1, 0, g1.nodes.size() / 2, 0));
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().updates_accepted == 2 && server.stats().updates_accepted == 2; }));
  ASSERT_TRUE(matcher.flush(30.0));
  ASSERT_TRUE(waitUntil([&] { return server.stats().constraints_accepted == 3; }));
  const std::vector<building::InterGraphConstraint> first = server.snapshot().first.constraints();

  graphs.publish(toUpdate(g1, g1.nodes.size() / 2, g1.nodes.size(), 1));
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().updates_accepted == 3 && server.stats().updates_accepted == 3; }));
  ASSERT_TRUE(matcher.flush(30.0));
  ASSERT_TRUE(waitUntil([&] {
    return server.stats().constraints_retracted == 3 && server.stats().constraints_accepted == 6;
  }));
  EXPECT_EQ(matcher.stats().constraints_retracted, 3u);
  EXPECT_EQ(matcher.stats().constraints_published, 6u);
  auto heldOnly = [&](const building::BuildingGraph& b) {
    // Every held constraint places graph 1's node where the truth does, none where the
    // first pass did.
    ASSERT_EQ(b.constraints().size(), 3u);
    expectHeldAtTruth(b, truth);
    for (const auto& c : b.constraints())
      for (const auto& old : first) EXPECT_FALSE(old.node_from == c.node_from && old.node_to == c.node_to);
  };
  heldOnly(server.snapshot().first);
  matcher.deactivate();
  server.deactivate();
  server.cleanup();

  runtime::Context restarted_context(onDomain(219));
  graph_server::GraphServer restarted(restarted_context, common::ConfigNode::loadString(server_parameters),
                                      "graph_server");
  restarted.configure();
  EXPECT_EQ(restarted.stats().replayed_from_journal, 3u + 6u + 3u);  // updates, constraints, retractions
  heldOnly(restarted.snapshot().first);
}

// Passes on growing graphs publish only what the pass before placed the same way: a wrong
// placement that the next pass overturns is never published, and a right one is published
// by the second pass that finds it.
TEST(FloorMatcherComponent, GrowthPassesPublishOnlyWhatThePassBeforeConfirmed) {
  const TwoFloors two;
  ASSERT_EQ(two.floors.graphs.size(), 2u);
  const auto& g0 = two.floors.graphs[0];
  const auto& g1 = two.floors.graphs[1];
  const geometry::Pose2& truth = two.truth;
  const geometry::Pose2& wrong = two.wrong;
  runtime::Context context(onDomain(214));
  ReceivedConstraints constraints(context);
  std::mutex& mutex = constraints.mutex;
  std::vector<storey_msgs::msg::InterFloorConstraint>& received = constraints.messages;
  GrowingScriptedMatcher running(context, {wrong, truth});
  ScriptedMatcher& matcher = running.matcher;
  FloorGraphPublisher& graphs = running.graphs;
  // Three growth passes: graph 1 in thirds (the first with graph 0 whole).
  graphs.publish(toUpdate(g0, 0, g0.nodes.size(), 0));
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().updates_accepted == 1; }));
  const std::size_t third = g1.nodes.size() / 3;
  for (std::uint32_t i = 0; i < 3; ++i) {
    graphs.publish(toUpdate(g1, i * third, (i + 1) * third, i));
    // (A pass counts itself and what it published or held back under one lock.)
    ASSERT_TRUE(waitUntil([&] { return matcher.stats().matchings == i + 1; })) << "pass " << i + 1;
    const FloorMatcherStats stats = matcher.stats();
    if (i == 0) {  // wrong, and nothing before it: held back
      EXPECT_EQ(stats.constraints_published, 0u);
      EXPECT_EQ(stats.constraints_unconfirmed, 3u);
    } else if (i == 1) {  // right, but the pass before placed graph 1 elsewhere
      EXPECT_EQ(stats.constraints_published, 0u);
      EXPECT_EQ(stats.constraints_unconfirmed, 6u);
    } else {  // right again: published
      EXPECT_EQ(stats.constraints_published, 3u);
      EXPECT_EQ(stats.constraints_retracted, 0u);
    }
  }
  ASSERT_TRUE(waitUntil([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return received.size() == 3u;
  }));
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& m : received) EXPECT_FALSE(m.retracted());
  }
}

// A pass that another graph's growth triggered sees the young graph as the pass before
// did: agreeing with it is no more evidence. Confirmation waits for a pass on
// retraction.confirm_growth (20 %) more of one of the pair's graphs.
TEST(FloorMatcherComponent, APassOnTheSameYoungGraphDoesNotConfirm) {
  const TwoFloors two;
  const auto& g0 = two.floors.graphs[0];
  const auto& g1 = two.floors.graphs[1];
  floor::FloorGraph g2 = g0;  // a third graph, only to trigger a pass
  g2.graph_id = 9;
  runtime::Context context(onDomain(165));
  GrowingScriptedMatcher running(context, {two.truth});
  ScriptedMatcher& matcher = running.matcher;
  FloorGraphPublisher& graphs = running.graphs;
  graphs.publish(toUpdate(g0, 0, g0.nodes.size(), 0));
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().updates_accepted == 1; }));
  const std::size_t half = g1.nodes.size() / 2;
  ASSERT_GE(half, 10u);
  graphs.publish(toUpdate(g1, 0, half, 0));
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().matchings == 1; }));
  graphs.publish(toUpdate(g2, 0, g2.nodes.size(), 0));  // graphs 0 and 1 as they were
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().matchings == 2; }));
  EXPECT_EQ(matcher.stats().constraints_published, 0u);
  EXPECT_EQ(matcher.stats().constraints_unconfirmed, 6u);
  graphs.publish(toUpdate(g1, half, g1.nodes.size(), 1));  // graph 1 doubled
  ASSERT_TRUE(waitUntil([&] { return matcher.stats().matchings == 3; }));
  EXPECT_EQ(matcher.stats().constraints_published, 3u);
  EXPECT_EQ(matcher.stats().constraints_unconfirmed, 6u);
}

// What a growth pass held back is published when the input settles: by a flush, or after
// match_after_idle without growth. Nothing is lost because no further pass came.
TEST(FloorMatcherComponent, WhatAGrowthPassHeldBackIsPublishedWhenTheInputSettles) {
  const TwoFloors two;
  const auto& g0 = two.floors.graphs[0];
  const auto& g1 = two.floors.graphs[1];
  const geometry::Pose2& truth = two.truth;
  for (const bool by_flush : {true, false}) {
    runtime::Context context(onDomain(by_flush ? 204 : 205));
    ScriptedMatcher matcher(context,
                            std::string("{min_nodes: 10, match_while_growing: true, match_after_idle: ") +
                                (by_flush ? "0" : "0.5") + "}",
                            {truth});
    matcher.configure();
    matcher.activate();
    FloorGraphPublisher graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
    graphs.publish(toUpdate(g0, 0, g0.nodes.size(), 0));
    graphs.publish(toUpdate(g1, 0, g1.nodes.size(), 0));
    waitUntil([&] { return matcher.stats().constraints_unconfirmed >= 3; });
    EXPECT_EQ(matcher.stats().constraints_unconfirmed, 3u) << (by_flush ? "flush" : "idle");
    if (by_flush) {
      EXPECT_TRUE(matcher.flush(30.0));
    }
    waitUntil([&] { return matcher.stats().constraints_published >= 3; });
    EXPECT_EQ(matcher.stats().constraints_published, 3u) << (by_flush ? "flush" : "idle");
    EXPECT_EQ(matcher.stats().matchings, 1u) << "released without matching again";
    matcher.deactivate();
  }
}

// A pass still running when the matcher is deactivated (a deployment stopped while it
// matches) publishes its constraints before the publisher goes quiet.
TEST(FloorMatcherComponent, APassRunningWhenDeactivatedStillPublishes) {
  const TwoFloors two;
  runtime::ContextOptions isolated;
  isolated.isolated = true;
  runtime::Context context(isolated);
  ReceivedConstraints received(context);
  SlowScriptedMatcher matcher(context,
                              "{min_nodes: 10, match_while_growing: false, match_after_idle: 0.2}",
                              {two.truth}, 1.0);
  matcher.configure();
  matcher.activate();
  FloorGraphPublisher graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
  ASSERT_TRUE(graphs.waitForSubscribers(1, 5.0));
  for (const auto& g : two.floors.graphs) graphs.publish(toUpdate(g, 0, g.nodes.size(), 0));
  ASSERT_TRUE(waitUntil([&] { return matcher.started.load(); }));
  matcher.deactivate();
  EXPECT_EQ(matcher.stats().constraints_published, 3u);
  EXPECT_TRUE(waitUntil([&] {
    std::lock_guard<std::mutex> lock(received.mutex);
    return received.messages.size() == 3;
  })) << "constraints dropped at deactivation";
  matcher.cleanup();
}

// A matcher restarted in a new process has no memory of what its predecessor published,
// and the dead writer's topic history is gone with it; the graph server's state lists the
// constraints it holds, so the new matcher adopts them and withdraws those its pass
// places elsewhere.
TEST(FloorMatcherComponent, ARestartedMatcherWithdrawsWhatItsPredecessorPublished) {
  const TwoFloors two;
  const eval::SimulatedFloors& floors = two.floors;
  ASSERT_EQ(floors.graphs.size(), 2u);
  const geometry::Pose2& truth = two.truth;
  const geometry::Pose2& wrong = two.wrong;
  const std::string parameters = "{min_nodes: 10, match_while_growing: false, match_after_idle: 0}";
  runtime::Context context(onDomain(206));
  graph_server::GraphServer server(
      context, common::ConfigNode::loadString("{optimize_min_period: 0.05, publish_maps: false}"), "graph_server");
  server.configure();
  server.activate();
  FloorGraphPublisher graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
  {
    ScriptedMatcher first(context, parameters, {wrong});
    first.configure();
    first.activate();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
    for (const auto& g : floors.graphs) graphs.publish(toUpdate(g, 0, g.nodes.size(), 0));
    ASSERT_TRUE(waitUntil([&] { return first.stats().updates_accepted == 2 && server.stats().updates_accepted == 2; }));
    ASSERT_TRUE(first.flush(30.0));
    ASSERT_TRUE(waitUntil([&] { return server.stats().constraints_accepted == 3; }));
    ASSERT_TRUE(server.waitOptimized(10.0));
    first.deactivate();
    first.cleanup();
  }  // gone, with its writer's history
  ScriptedMatcher second(context, parameters, {truth});
  second.configure();
  second.activate();
  // It gets the graphs and the server's states from their topics' history.
  ASSERT_TRUE(waitUntil([&] {
    return second.stats().updates_accepted == 2 && second.stats().states_received >= server.stats().optimisations;
  }));
  ASSERT_TRUE(second.flush(30.0));
  ASSERT_TRUE(waitUntil([&] {
    return server.stats().constraints_retracted == 3 && server.stats().constraints_accepted == 6;
  }));
  EXPECT_EQ(second.stats().constraints_adopted, 3u);
  EXPECT_EQ(second.stats().constraints_retracted, 3u);
  const building::BuildingGraph held = server.snapshot().first;
  ASSERT_EQ(held.constraints().size(), 3u);
  expectHeldAtTruth(held, truth);
  second.deactivate();
  server.deactivate();
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
  EXPECT_EQ(o.trigger.min_new_nodes, 7);
  EXPECT_EQ(o.matcher.min_constraints, 4);
}

}  // namespace
}  // namespace storey::floor_matcher
