#include "storey/floor_mapper/floor_mapper_component.h"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "storey/catalog/all_components.h"
#include "storey/floor_mapper/conversions.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/subscription.h"
#include "synthetic_world.h"
#include "test_support.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::floor_mapper {
namespace {

using geometry::Pose2;
using UpdateMsg = storey_msgs::msg::FloorGraphUpdate;
using UpdateSub = runtime::Subscription<UpdateMsg, storey_msgs::msg::FloorGraphUpdatePubSubType>;

runtime::ContextOptions onDomain(int domain) {
  runtime::ContextOptions options;
  options.domain_id = domain;
  return options;
}

// The shipped parameters with another robot name and graph topic.
common::ConfigNode parametersFor(const std::string& robot, const std::string& topic) {
  std::ifstream in(storey::test::sourceDir() + "/config/floor_mapper.yaml");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  auto replace = [&](const std::string& from, const std::string& to) { text.replace(text.find(from), from.size(), to); };
  replace("robot: robot1", "robot: " + robot);
  replace("floor_graph_topic: storey/floor_graphs", "floor_graph_topic: " + topic);
  return common::ConfigNode::loadString(text, "floor_mapper.yaml");
}

// The floor detector's progress: it has decided up to `decided_at` (the mapper holds scans
// until then).
storey_msgs::msg::FloorEvent progressEvent(const std::string& robot, double decided_at) {
  storey_msgs::msg::FloorEvent m;
  m.robot(robot);
  m.kind(storey_msgs::msg::FloorEvent_Constants::KIND_PROGRESS);
  m.stamp(runtime::toTimeMessage(decided_at));
  m.decided_at(runtime::toTimeMessage(decided_at));
  return m;
}

// A robot's inputs as the mapper reads them: scans, odometry and the detector's events,
// published once the mapper has subscribed to each.
struct RobotInputs {
  runtime::Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType> scans;
  runtime::Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom;
  runtime::Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType> events;
  RobotInputs(runtime::Context& context, const std::string& robot)
      : scans(context, "/" + robot + "/scan", runtime::TopicKind::kSensor),
        odom(context, "/" + robot + "/odom", runtime::TopicKind::kSensor),
        events(context, "/" + robot + "/floor_events", runtime::TopicKind::kGraph) {}
  bool matched() {
    return scans.waitForSubscribers(1, 5.0) && odom.waitForSubscribers(1, 5.0) &&
           events.waitForSubscribers(1, 5.0);
  }
};

bool waitFor(const std::function<bool()>& done, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

TEST(FloorMapperComponent, MapsTwoFloorsAndPublishesTheirGraphs) {
  runtime::Context context(onDomain(226));
  std::mutex mutex;
  std::vector<UpdateMsg> received;
  UpdateSub updates(context, "fm_graphs", runtime::TopicKind::kGraph, [&](const UpdateMsg& m) {
    std::lock_guard<std::mutex> lock(mutex);
    received.push_back(m);
  });
  FloorMapperComponent component(context, parametersFor("fm_robot", "fm_graphs"), "mapper");
  component.configure();
  component.activate();

  RobotInputs inputs(context, "fm_robot");
  ASSERT_TRUE(inputs.matched());
  auto& scans = inputs.scans;
  auto& odom = inputs.odom;
  auto& events = inputs.events;

  const mapping::test::World office = mapping::test::officeWorld();
  double t = 100.0;
  // The test plays the floor detector too: its progress, on the events topic, lets the
  // mapper pass scans on (it holds them until the detector has decided past them).
  auto progress = [&](double decided_at) { events.publish(progressEvent("fm_robot", decided_at)); };
  auto drive = [&](double y) {
    for (int i = 0; i < 12; ++i) {
      const Pose2 pose(1.5 + 0.3 * i, y, 0.0);
      sensor::OdometrySample o;
      o.stamp = t;
      o.pose = pose;
      odom.publish(runtime::toMessage(o));
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      // The laser at base_link: no tf_static needed (another frame waits for its mounting).
      scans.publish(runtime::toMessage(office.scan(pose, t), "fm_robot/base_link"));
      progress(t);
      std::this_thread::sleep_for(std::chrono::milliseconds(40));
      t += 0.5;
    }
  };
  auto waitForNodes = [&](std::size_t n) {
    return waitFor([&] { return component.nodeCount() >= n; }, 20.0);
  };
  drive(1.2);
  ASSERT_TRUE(waitForNodes(8));
  storey_msgs::msg::FloorEvent event;
  event.robot("fm_robot");
  event.kind(storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_STARTED);
  event.floor_id(storey_msgs::msg::FloorEvent_Constants::FLOOR_UNKNOWN);
  event.stamp(runtime::toTimeMessage(t - 0.4));
  event.decided_at(runtime::toTimeMessage(t - 0.3));
  events.publish(event);
  event.stamp(runtime::toTimeMessage(t - 0.2));
  event.decided_at(runtime::toTimeMessage(t - 0.1));
  event.kind(storey_msgs::msg::FloorEvent_Constants::KIND_TRANSIT_ENDED);
  event.floor_id(1);
  event.floor_height(3.0);
  events.publish(event);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::size_t before = component.nodeCount();
  drive(6.5);  // floor 1 (the same room plan: a new graph anyway)
  ASSERT_TRUE(waitForNodes(before + 8));

  ASSERT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        std::set<int> floors;
        for (const auto& m : received) floors.insert(m.floor_id());
        return floors.size() == 2;
      },
      10.0));
  std::lock_guard<std::mutex> lock(mutex);
  std::map<std::uint32_t, std::uint32_t> next_sequence;
  std::size_t nodes = 0, edges = 0;
  for (const auto& m : received) {
    EXPECT_EQ(m.robot(), "fm_robot");
    EXPECT_EQ(m.sequence_number(), next_sequence[m.floor_graph_id()]++) << "graph " << m.floor_graph_id();
    nodes += m.new_nodes().size();
    edges += m.new_edges().size();
    for (const auto& n : m.new_nodes()) EXPECT_FALSE(n.ranges().empty());
    if (m.floor_id() == 1) {
      EXPECT_DOUBLE_EQ(m.floor_height(), 3.0);
    }
  }
  EXPECT_EQ(next_sequence.size(), 2u);  // two floor graphs
  EXPECT_GE(nodes, 16u);
  EXPECT_GE(edges, 2 * (nodes - 2));  // odometry + scan match between consecutive nodes
  component.deactivate();
  component.cleanup();
}

// Standard ROS 2 frames, without the robot's namespace: odometry of `base_frame`, the laser
// mounted by `mounting` (parent, child, pose) on /tf_static. Returns the sensor offsets of
// the nodes the mapper publishes.
std::vector<Pose2> mountedOffsets(
    int domain, const std::string& base_frame,
    const std::vector<std::tuple<std::string, std::string, Pose2>>& mounting) {
  runtime::Context context(onDomain(domain));
  std::mutex mutex;
  std::vector<Pose2> offsets;
  UpdateSub updates(context, "fm_graphs", runtime::TopicKind::kGraph, [&](const UpdateMsg& m) {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& n : m.new_nodes())
      offsets.emplace_back(n.sensor_x(), n.sensor_y(), n.sensor_theta());
  });
  FloorMapperComponent component(context, parametersFor("fm_robot", "fm_graphs"), "mapper");
  component.configure();
  component.activate();
  runtime::Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType> tf_static(
      context, "tf_static", runtime::TopicKind::kGraph);
  RobotInputs inputs(context, "fm_robot");
  EXPECT_TRUE(inputs.matched());
  auto& scans = inputs.scans;
  auto& odom = inputs.odom;
  auto& events = inputs.events;
  tf2_msgs::msg::TFMessage tf;
  Pose2 laser;  // the laser in base_frame
  for (const auto& [parent, child, pose] : mounting) {
    tf.transforms().push_back(runtime::toTransform(pose, 100.0, parent, child));
    laser = laser * pose;
  }
  tf_static.publish(tf);
  const mapping::test::World office = mapping::test::officeWorld();
  double t = 100.0;
  for (int i = 0; i < 6; ++i, t += 0.5) {
    const Pose2 pose(1.5 + 0.3 * i, 1.2, 0.0);
    sensor::OdometrySample o;
    o.stamp = t;
    o.pose = pose;
    odom.publish(runtime::toMessage(o, "odom", base_frame));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    sensor::LaserScan scan = office.scan(pose * laser, t);
    scans.publish(runtime::toMessage(scan, "laser"));
    events.publish(progressEvent("fm_robot", t));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Scans whose mounting is unknown wait for it: only mounted scans become nodes here.
  EXPECT_TRUE(waitFor([&] { return component.nodeCount() >= 1; }, 3.0)) << "no scan was mounted";
  component.flush(1.0);
  EXPECT_TRUE(waitFor(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return !offsets.empty();
      },
      3.0));
  component.deactivate();
  component.cleanup();
  std::lock_guard<std::mutex> lock(mutex);
  return offsets;
}

TEST(FloorMapperComponent, TakesTheLaserMountingOnAPlainBaseLink) {
  const auto offsets =
      mountedOffsets(53, "base_link", {{"base_link", "laser", Pose2(0.2, 0.05, 0.1)}});
  ASSERT_FALSE(offsets.empty());
  for (const Pose2& offset : offsets) {
    EXPECT_NEAR(offset.x(), 0.2, 1e-9);
    EXPECT_NEAR(offset.y(), 0.05, 1e-9);
    EXPECT_NEAR(offset.theta(), 0.1, 1e-9);
  }
}

// base_footprint -> base_link -> laser: the mounting is the composed chain.
TEST(FloorMapperComponent, ComposesTheMountingFromBaseFootprint) {
  const auto offsets = mountedOffsets(54, "base_footprint",
                                      {{"base_footprint", "base_link", Pose2(0.1, 0.0, 0.0)},
                                       {"base_link", "laser", Pose2(0.2, 0.0, M_PI / 2)}});
  ASSERT_FALSE(offsets.empty());
  for (const Pose2& offset : offsets) {
    EXPECT_NEAR(offset.x(), 0.3, 1e-9);
    EXPECT_NEAR(offset.y(), 0.0, 1e-9);
    EXPECT_NEAR(offset.theta(), M_PI / 2, 1e-9);
  }
}

// Scans without odometry near their stamps are counted as not mapped (the map job's report
// warns when that is most of a robot's scans).
TEST(FloorMapperComponent, CountsTheScansItCouldNotMap) {
  runtime::Context context(onDomain(168));
  FloorMapperComponent component(context, parametersFor("fc_robot", "fc_graphs"), "mapper");
  component.configure();
  component.activate();
  RobotInputs inputs(context, "fc_robot");
  ASSERT_TRUE(inputs.matched());
  auto& scans = inputs.scans;
  auto& odom = inputs.odom;
  auto& events = inputs.events;
  const mapping::test::World office = mapping::test::officeWorld();
  // Odometry for the first 4 of 10 scans (1 s apart), then none: 6 scans have no odometry
  // within max_odometry_gap (0.5 s).
  for (int i = 0; i < 10; ++i) {
    const double t = 100.0 + i;
    const Pose2 pose(1.5 + 0.3 * i, 1.2, 0.0);
    if (i < 4) {
      sensor::OdometrySample o;
      o.stamp = t;
      o.pose = pose;
      odom.publish(runtime::toMessage(o));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    scans.publish(runtime::toMessage(office.scan(pose, t), "fc_robot/base_link"));
    events.publish(progressEvent("fc_robot", t));
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
  }
  ASSERT_TRUE(waitFor([&] { return component.scanCounts().received == 10; }, 10.0));
  ASSERT_TRUE(component.flush(5.0));
  const ScanCounts counts = component.scanCounts();
  EXPECT_EQ(counts.without_odometry, 6u);
  EXPECT_EQ(counts.rejected, 0u);
  EXPECT_EQ(counts.notMapped(), 6u);
  component.deactivate();
  component.cleanup();
}

TEST(FloorMapperComponent, BadParametersNameTheKey) {
  runtime::Context context(onDomain(227));
  FloorMapperComponent component(
      context,
      common::ConfigNode::loadString("{robot: r, slam: {laser: {range_noise: 7}}}", "p.yaml"), "m");
  try {
    component.configure();
    FAIL() << "configured with range_noise 7";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("range_noise"), std::string::npos) << e.what();
  }
}

// Floor-graph ids are keys across the fleet: each robot's mapper starts its own range.
TEST(FloorMapperComponent, RobotsGetDistinctFloorGraphIdRanges) {
  std::set<int> bases;
  for (int i = 1; i <= 30; ++i) {
    const int base = floorGraphIdBase("robot" + std::to_string(i));
    EXPECT_EQ(base % 1000, 0);
    EXPECT_GE(base, 0);
    EXPECT_LE(base, 1048575 * 1000);  // graph id * 1000000 + node stays within int64 node ids
    bases.insert(base);
  }
  EXPECT_EQ(bases.size(), 30u);
  EXPECT_EQ(floorGraphIdBase("robot1"), floorGraphIdBase("robot1"));  // deterministic
  const auto options = readFloorMapperComponentOptions(
      common::ConfigNode::loadString("{robot: r, first_floor_graph_id: 7000, slam: {}}", "p.yaml"));
  EXPECT_EQ(options.first_floor_graph_id, 7000);
  EXPECT_THROW(readFloorMapperComponentOptions(
                   common::ConfigNode::loadString("{robot: r, first_floor_graph_id: -2, slam: {}}", "p.yaml")),
               common::ConfigError);
}

TEST(FloorMapperComponent, RegisteredInTheCatalog) {
  runtime::ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  EXPECT_TRUE(registry.has("floor_mapper"));
}

TEST(FloorMapperConversions, EdgesAndPosesOnTheWire) {
  floor::FloorGraph graph;
  graph.robot = "r";
  graph.graph_id = 4;
  graph.floor_id = 2;
  graph.floor_height = 6.0;
  floor::FloorNode node;
  node.id = 7;
  node.stamp = 12.5;
  node.pose = Pose2(1, 2, 0.3);
  node.scan.angle_min = -1;
  node.scan.angle_increment = 0.01;
  node.scan.range_min = 0.1;
  node.scan.range_max = 10;
  node.scan.ranges = {1.0f, 2.0f};
  graph.nodes.push_back(node);
  mapping::GraphUpdate update;
  update.new_nodes.push_back(node);
  Eigen::Matrix3d info;
  info << 10, 1, 0, 1, 20, 0, 0, 0, 30;
  update.new_edges.push_back({6, 7, Pose2(0.5, 0, 0.1), info, floor::EdgeKind::kLoopClosure});
  const UpdateMsg m = toMessage(graph, update, 3);
  EXPECT_EQ(m.floor_graph_id(), 4u);
  EXPECT_EQ(m.sequence_number(), 3u);
  ASSERT_EQ(m.new_nodes().size(), 1u);
  EXPECT_EQ(m.new_nodes()[0].ranges().size(), 2u);
  ASSERT_EQ(m.new_edges().size(), 1u);
  EXPECT_EQ(m.new_edges()[0].kind(), storey_msgs::msg::FloorGraphEdge_Constants::KIND_LOOP_CLOSURE);
  EXPECT_DOUBLE_EQ(m.new_edges()[0].information()[1], 1.0);
  EXPECT_DOUBLE_EQ(m.new_edges()[0].information()[4], 20.0);
  ASSERT_EQ(m.optimized_poses().size(), 1u);
  EXPECT_DOUBLE_EQ(m.optimized_poses()[0].theta(), 0.3);
}

}  // namespace
}  // namespace storey::floor_mapper
