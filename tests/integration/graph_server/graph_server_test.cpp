#include "storey/graph_server/graph_server.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

#include "storey/graph_server/conversions.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/subscription.h"
#include "test_support.h"

namespace storey::graph_server {
namespace {

using geometry::Pose2;

runtime::ContextOptions onDomain(int domain) {
  runtime::ContextOptions options;
  options.domain_id = domain;
  return options;
}

// A floor graph of `count` nodes along a line, in its own frame.
storey_msgs::msg::FloorGraphUpdate makeUpdate(int graph_id, int floor_id, double height,
                                              double first_stamp = 10.0) {
  storey_msgs::msg::FloorGraphUpdate u;
  u.robot("robot_a");
  u.floor_graph_id(graph_id);
  u.floor_id(floor_id);
  u.floor_height(height);
  for (int i = 0; i < 5; ++i) {
    storey_msgs::msg::FloorGraphNode n;
    n.node_id(i);
    n.floor_graph_id(graph_id);
    n.stamp(runtime::toTimeMessage(first_stamp + i));
    n.x(i);
    n.y(0.2 * i);
    n.theta(0.05 * i);
    n.angle_min(-1.5f);
    n.angle_increment(0.1f);
    n.range_min(0.1f);
    n.range_max(20.f);
    n.ranges(std::vector<float>(31, 3.0f));
    u.new_nodes().push_back(n);
    if (i > 0) {
      storey_msgs::msg::FloorGraphEdge e;
      e.from_node(i - 1);
      e.to_node(i);
      const Pose2 rel = Pose2(i - 1, 0.2 * (i - 1), 0.05 * (i - 1)).between(Pose2(i, 0.2 * i, 0.05 * i));
      e.dx(rel.x());
      e.dy(rel.y());
      e.dtheta(rel.theta());
      e.information({100, 0, 0, 0, 100, 0, 0, 0, 400});
      u.new_edges().push_back(e);
    }
  }
  return u;
}

storey_msgs::msg::InterFloorConstraint makeConstraint(int id, int node, const Pose2& offset) {
  // Floor graph 1's frame sits at `offset` in floor graph 0's frame.
  const Pose2 p0(node, 0.2 * node, 0.05 * node);
  const Pose2 p1 = offset * p0;
  const Pose2 rel = p0.between(p1);
  storey_msgs::msg::InterFloorConstraint c;
  c.constraint_id(id);
  c.from_floor_graph(0);
  c.from_node(node);
  c.to_floor_graph(1);
  c.to_node(node);
  c.dx(rel.x());
  c.dy(rel.y());
  c.dtheta(rel.theta());
  c.dz(3.0);
  c.information({50, 0, 0, 0, 50, 0, 0, 0, 200});
  return c;
}

class GraphServerTest : public ::testing::Test {
 protected:
  void publishBuilding(runtime::Context& context, const Pose2& offset, bool constraints_first) {
    runtime::Publisher<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType> graphs(
        context, "storey/floor_graphs", runtime::TopicKind::kGraph);
    runtime::Publisher<storey_msgs::msg::InterFloorConstraint, storey_msgs::msg::InterFloorConstraintPubSubType>
        constraints(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
    if (!constraints_first) {
      graphs.publish(makeUpdate(0, 0, 0.0));
      graphs.publish(makeUpdate(1, 1, 3.0));
    }
    for (int k : {1, 2, 3}) constraints.publish(makeConstraint(k, k, offset));
    if (constraints_first) {
      graphs.publish(makeUpdate(0, 0, 0.0));
      graphs.publish(makeUpdate(1, 1, 3.0));
    }
  }
};

TEST_F(GraphServerTest, OptimisesAndPublishesTheBuilding) {
  runtime::Context context(onDomain(200));
  std::atomic<int> states{0};
  std::mutex mutex;
  storey_msgs::msg::BuildingState last;
  runtime::Subscription<storey_msgs::msg::BuildingState, storey_msgs::msg::BuildingStatePubSubType> state_sub(
      context, "storey/building_state", runtime::TopicKind::kGraph, [&](const storey_msgs::msg::BuildingState& s) {
        std::lock_guard<std::mutex> lock(mutex);
        last = s;
        ++states;
      });
  GraphServer server(context, common::ConfigNode::loadString("{optimize_min_period: 0.05}"), "graph_server");
  server.configure();
  server.activate();
  const Pose2 offset(1.0, -0.5, 0.3);
  publishBuilding(context, offset, /*constraints_first=*/true);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline) {
    if (server.stats().constraints_accepted == 3 && server.waitOptimized(0.1)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(server.stats().updates_accepted, 2u);
  ASSERT_EQ(server.stats().constraints_accepted, 3u);
  const auto [graph, solution] = server.snapshot();
  const auto* placement = solution.placement(1);
  ASSERT_NE(placement, nullptr);
  EXPECT_TRUE(placement->aligned);
  EXPECT_NEAR(placement->transform.x(), offset.x(), 1e-6);
  EXPECT_NEAR(placement->transform.y(), offset.y(), 1e-6);
  EXPECT_NEAR(placement->transform.theta(), offset.theta(), 1e-6);
  while (std::chrono::steady_clock::now() < deadline && states == 0)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GT(states.load(), 0);
  server.deactivate();
  server.cleanup();
}

TEST_F(GraphServerTest, RestartFromJournalLosesNothing) {
  const std::string journal = test::makeTempDir() + "/graph.journal";
  const std::string params = "{optimize_min_period: 0.05, journal: '" + journal + "', publish_maps: false}";
  const Pose2 offset(-2.0, 1.0, -0.2);
  building::BuildingSolution before;
  {
    runtime::Context context(onDomain(201));
    GraphServer server(context, common::ConfigNode::loadString(params), "graph_server");
    server.configure();
    server.activate();
    publishBuilding(context, offset, false);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline && server.stats().constraints_accepted < 3)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(server.waitOptimized(5.0));
    before = server.snapshot().second;
  }  // the server goes away as if it died: nothing but the journal survives
  runtime::Context context(onDomain(202));
  GraphServer restarted(context, common::ConfigNode::loadString(params), "graph_server");
  restarted.configure();
  restarted.activate();
  EXPECT_EQ(restarted.stats().replayed_from_journal, 5u);
  ASSERT_TRUE(restarted.waitOptimized(5.0));
  const auto after = restarted.snapshot().second;
  ASSERT_NE(after.placement(1), nullptr);
  EXPECT_NEAR(after.placement(1)->transform.x(), before.placement(1)->transform.x(), 1e-9);
  EXPECT_NEAR(after.final_chi2, before.final_chi2, 1e-9);
}

// Group commit: records accepted between two published states share one fdatasync, and
// every one of them is in the journal by the time a state reflects it.
TEST_F(GraphServerTest, TheJournalSyncsOncePerBatchBeforeTheStateGoesOut) {
  const std::string journal = test::makeTempDir() + "/graph.journal";
  const std::string params =
      "{optimize_min_period: 0.5, journal: '" + journal + "', publish_maps: false}";
  runtime::Context context(onDomain(55));
  GraphServer server(context, common::ConfigNode::loadString(params), "graph_server");
  server.configure();
  server.activate();
  constexpr int kGraphs = 40;
  {
    runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                       storey_msgs::msg::FloorGraphUpdatePubSubType>
        graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
    ASSERT_TRUE(graphs.waitForSubscribers(1, 5.0));
    for (int g = 0; g < kGraphs; ++g) graphs.publish(makeUpdate(g, g, 3.0 * g));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline && server.stats().updates_accepted < kGraphs)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(server.stats().updates_accepted, static_cast<std::uint64_t>(kGraphs));
  ASSERT_TRUE(server.waitOptimized(10.0));
  const GraphServerStats stats = server.stats();
  // Each state the worker publishes is preceded by at most one sync of what came before it.
  EXPECT_GE(stats.journal_syncs, 1u);
  EXPECT_LE(stats.journal_syncs, stats.optimisations);
  EXPECT_LT(stats.journal_syncs, static_cast<std::uint64_t>(kGraphs));
  EXPECT_EQ(building::readJournal(journal).records.size(), static_cast<std::size_t>(kGraphs));
  server.deactivate();
  server.cleanup();
}

TEST_F(GraphServerTest, BadUpdatesAreRejectedAndCounted) {
  runtime::Context context(onDomain(203));
  GraphServer server(context, common::ConfigNode::loadString("{optimize_min_period: 0.05}"), "graph_server");
  server.configure();
  server.activate();
  runtime::Publisher<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType> graphs(
      context, "storey/floor_graphs", runtime::TopicKind::kGraph);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto bad = makeUpdate(0, 0, 0.0);
  bad.new_nodes()[2].x(std::nan(""));
  graphs.publish(bad);
  auto dangling = makeUpdate(1, 0, 0.0);
  dangling.new_edges()[0].to_node(77);
  graphs.publish(dangling);
  graphs.publish(makeUpdate(2, 0, 0.0));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline &&
         server.stats().rejected + server.stats().updates_accepted < 3)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(server.stats().rejected, 2u);
  EXPECT_EQ(server.stats().updates_accepted, 1u);
  EXPECT_EQ(server.snapshot().first.floorGraphs().size(), 1u);
}

// A retraction that arrives while its constraint still waits for its floor graphs drops
// it: the building never holds it. The other constraints are kept.
TEST_F(GraphServerTest, ARetractionDropsAConstraintStillWaitingForItsGraphs) {
  runtime::Context context(onDomain(224));
  GraphServer server(context, common::ConfigNode::loadString("{optimize_min_period: 0.05, publish_maps: false}"),
                     "graph_server");
  server.configure();
  server.activate();
  runtime::Publisher<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType> graphs(
      context, "storey/floor_graphs", runtime::TopicKind::kGraph);
  runtime::Publisher<storey_msgs::msg::InterFloorConstraint, storey_msgs::msg::InterFloorConstraintPubSubType>
      constraints(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
  const Pose2 offset(1.0, -0.5, 0.3);
  for (int k : {1, 2, 3}) constraints.publish(makeConstraint(k, k, offset));
  auto retraction = makeConstraint(2, 2, offset);
  retraction.retracted(true);
  retraction.reason("test");
  constraints.publish(retraction);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < deadline && server.stats().constraints_retracted < 1)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  graphs.publish(makeUpdate(0, 0, 0.0));
  graphs.publish(makeUpdate(1, 1, 3.0));
  while (std::chrono::steady_clock::now() < deadline && server.stats().constraints_accepted < 2)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(server.waitOptimized(5.0));
  EXPECT_EQ(server.stats().constraints_retracted, 1u);
  const auto held = server.snapshot().first.constraints();
  ASSERT_EQ(held.size(), 2u);
  for (const auto& c : held) EXPECT_NE(c.node_from, 2);
  server.deactivate();
  server.cleanup();
}

// A restarted server gets the topics' whole history again. Each update carries the poses
// of every node so far, which later updates move: applied again, an old update would put
// back old poses and be journalled a second time, and a constraint that was retracted
// would come back with its retraction. The journal must not grow, and the building must
// be the one before the restart.
TEST_F(GraphServerTest, AHistoryDeliveredAgainAfterARestartIsNotJournalledAgain) {
  const std::string journal = test::makeTempDir() + "/graph.journal";
  const std::string params =
      "{optimize_min_period: 0.05, journal: '" + journal + "', publish_maps: false}";
  std::vector<storey_msgs::msg::FloorGraphUpdate> history;
  for (int graph : {0, 1}) {
    const auto full = makeUpdate(graph, graph, 3.0 * graph);
    for (std::uint32_t k = 0; k < full.new_nodes().size(); ++k) {
      storey_msgs::msg::FloorGraphUpdate u = full;
      u.sequence_number(k);
      u.new_nodes() = {full.new_nodes()[k]};
      u.new_edges().clear();
      if (k > 0) u.new_edges() = {full.new_edges()[k - 1]};
      for (std::uint32_t i = 0; i <= k; ++i) {
        storey_msgs::msg::NodePose pose;
        pose.floor_graph_id(static_cast<std::uint32_t>(graph));
        pose.node_id(i);
        pose.x(full.new_nodes()[i].x() + 0.01 * k);  // each optimisation moves every node
        pose.y(full.new_nodes()[i].y());
        pose.theta(full.new_nodes()[i].theta());
        u.optimized_poses().push_back(pose);
      }
      history.push_back(u);
    }
  }
  const Pose2 offset(1.0, -0.5, 0.3);
  std::vector<storey_msgs::msg::InterFloorConstraint> constraints;
  for (int k : {1, 2, 3}) constraints.push_back(makeConstraint(k, k, offset));
  constraints.push_back(makeConstraint(2, 2, offset));
  constraints.back().retracted(true);
  constraints.back().reason("test");

  auto deliver = [&](GraphServer& server, runtime::Context& context) {
    runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                       storey_msgs::msg::FloorGraphUpdatePubSubType>
        graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
    runtime::Publisher<storey_msgs::msg::InterFloorConstraint,
                       storey_msgs::msg::InterFloorConstraintPubSubType>
        constraint_pub(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph);
    ASSERT_TRUE(graphs.waitForSubscribers(1, 5.0));
    ASSERT_TRUE(constraint_pub.waitForSubscribers(1, 5.0));
    for (const auto& u : history) graphs.publish(u);
    for (const auto& c : constraints) constraint_pub.publish(c);
    const std::size_t expected = history.size() + constraints.size();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    auto handled = [&] {
      const GraphServerStats s = server.stats();
      return s.updates_accepted + s.constraints_accepted + s.constraints_retracted +
             s.duplicates_ignored + s.rejected;
    };
    while (std::chrono::steady_clock::now() < deadline && handled() < expected)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_EQ(handled(), expected);
  };
  runtime::ContextOptions isolated;
  isolated.isolated = true;
  building::BuildingGraph before;
  std::size_t records = 0;
  {
    runtime::Context context(isolated);
    GraphServer server(context, common::ConfigNode::loadString(params), "graph_server");
    server.configure();
    server.activate();
    deliver(server, context);
    EXPECT_EQ(server.stats().rejected, 0u);
    before = server.snapshot().first;
    records = building::readJournal(journal).records.size();
    EXPECT_EQ(records, history.size() + constraints.size());
  }
  runtime::Context context(isolated);
  GraphServer restarted(context, common::ConfigNode::loadString(params), "graph_server");
  restarted.configure();
  restarted.activate();
  EXPECT_EQ(restarted.stats().replayed_from_journal, records);
  deliver(restarted, context);
  EXPECT_EQ(restarted.stats().duplicates_ignored, history.size() + constraints.size());
  EXPECT_EQ(building::readJournal(journal).records.size(), records);
  const auto after = restarted.snapshot().first;
  ASSERT_EQ(after.floorGraphs().size(), before.floorGraphs().size());
  for (const auto& [id, graph] : before.floorGraphs()) {
    const auto& again = after.floorGraphs().at(id);
    ASSERT_EQ(again.nodes.size(), graph.nodes.size());
    for (std::size_t i = 0; i < graph.nodes.size(); ++i)
      EXPECT_EQ(again.nodes[i].pose.x(), graph.nodes[i].pose.x())
          << "graph " << id << " node " << i;
    EXPECT_EQ(again.edges.size(), graph.edges.size());
  }
  EXPECT_EQ(after.constraints().size(), before.constraints().size());
  restarted.deactivate();
  restarted.cleanup();
}

// The live outputs per robot (REP 105): /tf building -> robot_a/odom, the pose with its
// floor, and the map of the floor the robot is on, each kept for a late subscriber.
TEST_F(GraphServerTest, PublishesEachRobotsOdomFramePoseFloorAndMap) {
  runtime::Context context(onDomain(64));
  GraphServer server(context, common::ConfigNode::loadString("{optimize_min_period: 0.05}"),
                     "graph_server");
  server.configure();
  server.activate();
  const Pose2 offset(1.0, -0.5, 0.3), odom_in_building(2.0, 1.0, 0.5);
  {
    runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                       storey_msgs::msg::FloorGraphUpdatePubSubType>
        graphs(context, "storey/floor_graphs", runtime::TopicKind::kGraph);
    runtime::Publisher<storey_msgs::msg::InterFloorConstraint,
                       storey_msgs::msg::InterFloorConstraintPubSubType>
        constraints(context, "storey/inter_floor_constraints", runtime::TopicKind::kGraph);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // discovery
    graphs.publish(makeUpdate(0, 0, 0.0));
    // The robot rode to floor 1 later; its odometry there, in the building frame, is
    // odom_in_building composed with it.
    auto upper = makeUpdate(1, 1, 3.0, 20.0);
    for (auto& n : upper.new_nodes()) {
      const Pose2 odometry = odom_in_building.inverse() * offset * Pose2(n.x(), n.y(), n.theta());
      n.odom_x(odometry.x());
      n.odom_y(odometry.y());
      n.odom_theta(odometry.theta());
    }
    graphs.publish(upper);
    for (int k : {1, 2, 3}) constraints.publish(makeConstraint(k, k, offset));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (std::chrono::steady_clock::now() < deadline) {
      if (server.stats().constraints_accepted == 3 && server.waitOptimized(0.1)) break;
    }
    ASSERT_EQ(server.stats().constraints_accepted, 3u);
  }
  // Subscribed after the fact: each topic keeps its last sample.
  std::mutex mutex;
  std::vector<geometry_msgs::msg::TransformStamped> tf;
  geometry_msgs::msg::PoseStamped pose;
  int floor = -1;
  nav_msgs::msg::OccupancyGrid map;
  runtime::Subscription<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_sub(
      context, "/tf", runtime::TopicKind::kLatest, [&](const tf2_msgs::msg::TFMessage& m) {
        std::lock_guard<std::mutex> lock(mutex);
        tf = m.transforms();
      });
  runtime::Subscription<geometry_msgs::msg::PoseStamped, geometry_msgs::msg::PoseStampedPubSubType>
      pose_sub(context, "/robot_a/pose", runtime::TopicKind::kLatest,
               [&](const geometry_msgs::msg::PoseStamped& m) {
                 std::lock_guard<std::mutex> lock(mutex);
                 pose = m;
               });
  runtime::Subscription<std_msgs::msg::Int32, std_msgs::msg::Int32PubSubType> floor_sub(
      context, "/robot_a/floor", runtime::TopicKind::kLatest, [&](const std_msgs::msg::Int32& m) {
        std::lock_guard<std::mutex> lock(mutex);
        floor = m.data();
      });
  runtime::Subscription<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>
      map_sub(context, "/robot_a/map", runtime::TopicKind::kLatest,
              [&](const nav_msgs::msg::OccupancyGrid& m) {
                std::lock_guard<std::mutex> lock(mutex);
                map = m;
              });
  visualization_msgs::msg::MarkerArray markers;
  runtime::Subscription<visualization_msgs::msg::MarkerArray,
                        visualization_msgs::msg::MarkerArrayPubSubType>
      markers_sub(context, "storey/building_markers", runtime::TopicKind::kLatest,
                  [&](const visualization_msgs::msg::MarkerArray& m) {
                    std::lock_guard<std::mutex> lock(mutex);
                    markers = m;
                  });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!tf.empty() && floor >= 0 && !map.data().empty() && !pose.header().frame_id().empty() &&
          !markers.markers().empty())
        break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(tf.size(), 1u);
  EXPECT_EQ(tf[0].header().frame_id(), "building");
  EXPECT_EQ(tf[0].child_frame_id(), "robot_a/odom");
  const Pose2 odom = runtime::fromTransform(tf[0]);
  EXPECT_NEAR(odom.x(), odom_in_building.x(), 1e-4);
  EXPECT_NEAR(odom.y(), odom_in_building.y(), 1e-4);
  EXPECT_NEAR(odom.theta(), odom_in_building.theta(), 1e-4);
  EXPECT_DOUBLE_EQ(tf[0].transform().translation().z(), 3.0);
  EXPECT_DOUBLE_EQ(runtime::fromTimeMessage(tf[0].header().stamp()), 24.0);
  EXPECT_EQ(floor, 1);
  EXPECT_EQ(pose.header().frame_id(), "building");
  const Pose2 newest = offset * Pose2(4.0, 0.8, 0.2);
  EXPECT_NEAR(pose.pose().position().x(), newest.x(), 1e-4);
  EXPECT_NEAR(pose.pose().position().y(), newest.y(), 1e-4);
  EXPECT_DOUBLE_EQ(pose.pose().position().z(), 3.0);
  EXPECT_DOUBLE_EQ(map.info().origin().position().z(), 3.0) << "the map of floor 1";
  for (const std::int8_t value : map.data()) ASSERT_TRUE(value == -1 || value == 0 || value == 100);
  // The building graph for RViz: everything before replaced, a line per floor graph at its
  // floor's height, the three constraints, a label per floor.
  namespace mk = visualization_msgs::msg::Marker_Constants;
  ASSERT_FALSE(markers.markers().empty());
  EXPECT_EQ(markers.markers()[0].action(), mk::DELETEALL);
  int strips = 0, labels = 0;
  for (const auto& m : markers.markers()) {
    EXPECT_EQ(m.header().frame_id(), "building");
    if (m.action() == mk::DELETEALL) continue;
    if (m.type() == mk::LINE_STRIP) {
      ++strips;
      ASSERT_FALSE(m.points().empty());
      EXPECT_DOUBLE_EQ(m.points()[0].z(), m.id() == 1 ? 3.0 : 0.0);
    } else if (m.type() == mk::LINE_LIST) {
      EXPECT_EQ(m.points().size(), 6u);
    } else if (m.type() == mk::TEXT_VIEW_FACING) {
      ++labels;
    }
  }
  EXPECT_EQ(strips, 2);
  EXPECT_EQ(labels, 2);
  server.deactivate();
  server.cleanup();
}

// nav2 costmaps take a published map as trinary (100 lethal, 0 free, -1 unknown): the
// floor maps carry the same classification as the PGM files storey writes.
TEST(GraphServerConversions, FloorMapsAreTrinary) {
  building::FloorMap floor;
  floor.floor_id = 0;
  sensor::LaserScan scan;
  scan.angle_min = -0.5;
  scan.angle_increment = 0.01;
  scan.range_max = 20.0;
  scan.ranges.assign(101, 3.0f);  // a wall 3 m ahead
  for (int i = 0; i < 10; ++i) floor.grid.insertScan(scan, Pose2(0.0, 0.0, 0.0));
  const nav_msgs::msg::OccupancyGrid msg = toMessage(floor, 1.0);
  const grid::GridFrame& f = floor.grid.frame();
  ASSERT_EQ(msg.data().size(), f.cellCount());
  std::map<int, std::size_t> counts;
  for (const std::int8_t value : msg.data()) ++counts[value];
  for (const auto& [value, count] : counts)
    EXPECT_TRUE(value == -1 || value == 0 || value == 100) << count << " cells of value " << value;
  auto valueAt = [&](double x, double y) {
    const Eigen::Vector2i c = f.cellOf(Eigen::Vector2d(x, y));
    return static_cast<int>(msg.data()[f.index(c.x(), c.y())]);
  };
  EXPECT_EQ(valueAt(3.01, 0.0), 100) << "the wall";
  EXPECT_EQ(valueAt(1.5, 0.0), 0) << "seen free";
  EXPECT_EQ(valueAt(-1.5, 0.0), -1) << "behind the laser";
  EXPECT_GT(counts[100], 40u);
  EXPECT_GT(counts[0], 500u);
}

TEST(GraphServerOptions, UnknownKeyIsAnError) {
  EXPECT_THROW(readGraphServerOptions(common::ConfigNode::loadString("{optimise_period: 1}", "gs.yaml")),
               common::ConfigError);
  EXPECT_THROW(readGraphServerOptions(common::ConfigNode::loadString("{optimize_min_period: -1}", "gs.yaml")),
               common::ConfigError);
}

}  // namespace
}  // namespace storey::graph_server
