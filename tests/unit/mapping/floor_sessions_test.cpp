// Floor sessions: a robot that leaves a floor and comes back elsewhere is localised
// globally in that floor's map before its graph is resumed; an ambiguous floor gives a new
// graph instead of a wrong tie.
#include "storey/mapping/floor_sessions.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "bare_options.h"
#include "floor_sessions_world.h"
#include "synthetic_world.h"
#include "test_support.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;

using test::asymmetricFloor;
using test::legs;
using test::Robot;
using test::upperFloor;

TEST(FloorSessions, ReturningRobotIsLocalisedGloballyAndResumesItsGraph) {
  const test::World floor0 = asymmetricFloor();
  const Pose2 start(1, 8, 0);
  // The relocalisation alone: floor 0's map as tracking alone made it (the successor matches
  // made on leaving would reshape it by about 0.1 m at its far end).
  Robot robot(test::bareOptions(), start);
  robot.drive(floor0, legs({{1, 8}, {14, 8}, {14, 4}, {8, 4}, {8, 1.5}, {2, 4}}, 0.0));
  const std::size_t nodes_before = robot.sessions.current().floorGraph().nodes.size();
  robot.ride(1, 3.0, Pose2(1, 1, 0.5));
  robot.drive(upperFloor(), legs({{1, 1}, {6, 1}, {6, 4}}, 0.5));
  // Back on floor 0 far from where it left (2, 4), heading unknown to the mapper.
  robot.ride(0, 0.0, Pose2(15, 3, M_PI));
  EXPECT_TRUE(robot.sessions.relocalizing());
  const auto results = robot.drive(floor0, legs({{15, 3}, {11, 3}, {11, 5}, {6, 5}}, M_PI));
  EXPECT_FALSE(robot.sessions.relocalizing());
  EXPECT_EQ(robot.sessions.stats().global_relocalizations, 1u);
  EXPECT_EQ(robot.sessions.stats().fallbacks, 0u);
  EXPECT_TRUE(robot.sessions.retired().empty());
  EXPECT_EQ(robot.sessions.floors().size(), 2u);  // the same graph of floor 0, not a third
  std::size_t first = results.size();
  for (std::size_t i = 0; i < results.size(); ++i)
    if (results[i].relocalized) first = i;
  ASSERT_LT(first, results.size());
  // The floor frame is the first pose; the relocalised pose is where the robot was.
  const auto& graph = robot.sessions.current().floorGraph();
  Pose2 truth_at = legs({{15, 3}, {11, 3}, {11, 5}, {6, 5}}, M_PI)[first];
  const Pose2 expected = start.between(truth_at);
  EXPECT_LT((results[first].pose.translation() - expected.translation()).norm(), 0.05);
  EXPECT_LT(std::abs(geometry::angleDiff(results[first].pose.theta(), expected.theta())), 0.02);
  EXPECT_GT(graph.nodes.size(), nodes_before + 1);  // the buffered chain and the tie
  bool tie = false;
  for (const auto& e : graph.edges)
    if (e.kind == floor::EdgeKind::kScanMatch && e.from < static_cast<int>(nodes_before) &&
        e.to >= static_cast<int>(nodes_before))
      tie = true;
  EXPECT_TRUE(tie);
  // Mapping goes on in the old frame: the last pose is where the robot is.
  robot.sessions.flush();
  const Pose2 last = robot.sessions.current().currentPose();
  const Pose2 last_expected = start.between(robot.truth);
  EXPECT_LT((last.translation() - last_expected.translation()).norm(), 0.1);
  // Every node of the chain is where it was recorded.
  for (const auto& node : graph.nodes) EXPECT_TRUE(node.pose.isFinite());
}

// The detector decides a ride's end seconds after it, when the robot may have left the
// cabin: the scans between the end and the decision belong to the floor reached, and the
// ones before the end (still riding) to none.
TEST(FloorSessions, ScansAfterTheRidesEndGoToTheFloorReached) {
  {
    Robot robot(FloorSlamOptions{}, Pose2(1, 8, 0));
    robot.drive(asymmetricFloor(), legs({{1, 8}, {8, 8}}, 0.0));
    robot.sessions.beginTransit();
    // Riding (in the cabin of floor 0's map: these must go nowhere).
    robot.drive(asymmetricFloor(), legs({{8, 8}, {8.6, 8}}, 0.0));
    const double ride_end = robot.t;
    // Out on floor 1 before the detector has decided.
    robot.arriveAt(Pose2(1, 1, 0.5));
    const auto arrival = legs({{1, 1}, {4, 1}}, 0.5);
    const auto held = robot.drive(upperFloor(), arrival);
    for (const auto& r : held) EXPECT_EQ(r.status, ScanStatus::kSkipped);
    const std::size_t floor0_nodes = robot.sessions.floors().at(0)->floorGraph().nodes.size();
    robot.sessions.endTransit(1, 3.0, ride_end);
    EXPECT_EQ(robot.sessions.floors().at(0)->floorGraph().nodes.size(), floor0_nodes);
    robot.drive(upperFloor(), legs({{4, 1}, {6, 1}, {6, 4}}, 0.0));
    robot.sessions.flush();
    const auto& graph = robot.sessions.floors().at(1)->floorGraph();
    ASSERT_FALSE(graph.nodes.empty());
    // The first node is the first scan after the end (the floor's frame), and the arrival is
    // mapped where it was.
    EXPECT_NEAR(graph.nodes.front().stamp, ride_end + 0.1, 1e-9);
    std::size_t checked = 0;
    for (const auto& node : graph.nodes) {
      const long k = std::lround((node.stamp - ride_end) / 0.1) - 1;
      if (k < 0 || k >= static_cast<long>(arrival.size())) continue;
      const Pose2 expected = arrival.front().between(arrival[static_cast<std::size_t>(k)]);
      EXPECT_LT((node.pose.translation() - expected.translation()).norm(), 0.1)
          << "node at " << node.stamp;
      ++checked;
    }
    EXPECT_GE(checked, 10u);  // 3 m at 0.2 m a node
    // Back on floor 0, a known floor: scans in the cabin look like any shaft, so the ones
    // before the decision are not fed to the global localisation.
    robot.sessions.beginTransit();
    const double second_end = robot.t;
    robot.arriveAt(Pose2(15, 3, M_PI));
    robot.drive(asymmetricFloor(), legs({{15, 3}, {12, 3}}, M_PI));
    robot.sessions.endTransit(0, 0.0, second_end);
    ASSERT_TRUE(robot.sessions.relocalizing());
    EXPECT_TRUE(robot.sessions.relocalizer()->buffer().empty());
  }
}

TEST(FloorSessions, NewGraphModeNeverRelocalises) {
  FloorSlamOptions options;
  options.relocalization.known_floor = "new_graph";
  Robot robot(options, Pose2(1, 8, 0));
  robot.drive(asymmetricFloor(), legs({{1, 8}, {8, 8}}, 0.0));
  robot.ride(1, 3.0, Pose2(1, 1, 0));
  robot.drive(upperFloor(), legs({{1, 1}, {4, 1}}, 0.0));
  robot.ride(0, 0.0, Pose2(8, 8, M_PI));
  EXPECT_FALSE(robot.sessions.relocalizing());
  EXPECT_EQ(robot.sessions.retired().size(), 1u);
  EXPECT_EQ(robot.sessions.floors().size(), 2u);
}

}  // namespace
}  // namespace storey::mapping
