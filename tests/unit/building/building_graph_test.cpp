#include "storey/building/building_graph.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <random>

#include "building_runs.h"
#include "storey/building/building_outputs.h"
#include "storey/building/building_scene.h"
#include "storey/building/building_summary.h"
#include "storey/building/isometric_view.h"
#include "test_support.h"

namespace storey::building {
namespace {

// A square loop of nodes in a floor graph's own frame, with exact odometry edges and a
// ring scan at every node.
floor::FloorGraph makeLoop(int graph_id, int floor_id, double height, const Pose2& frame_in_building,
                           std::vector<Pose2>* truth) {
  floor::FloorGraph g;
  g.graph_id = graph_id;
  g.floor_id = floor_id;
  g.floor_height = height;
  g.robot = "r" + std::to_string(graph_id);
  sensor::LaserScan scan;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / 90;
  scan.range_min = 0.1;
  scan.range_max = 10;
  scan.ranges.assign(90, 2.0f);
  for (int i = 0; i < 12; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.stamp = i;
    const int row = i / 4;  // rows of four
    n.pose = Pose2(i % 4, row, 0.1 * i);
    n.scan = scan;
    g.nodes.push_back(n);
    if (truth) truth->push_back(frame_in_building * n.pose);
  }
  chainEdges(g);
  return g;
}

TEST(BuildingGraph, ConstraintsPlaceTheSecondFloor) {
  const Pose2 frame0(0, 0, 0), frame1(3.0, -2.0, 0.4);
  std::vector<Pose2> truth0, truth1;
  BuildingGraph building;
  building.upsertFloorGraph(makeLoop(0, 0, 0.0, frame0, &truth0));
  building.upsertFloorGraph(makeLoop(1, 1, 3.0, frame1, &truth1));
  // Three exact constraints (as the matcher would find them).
  int id = 0;
  for (int k : {1, 5, 9})
    building.addConstraint(exactConstraint(id++, 0, k, 1, k + 1, truth0[k], truth1[k + 1], 3.0));
  const BuildingSolution s = building.optimize();
  ASSERT_EQ(s.placements.size(), 2u);
  EXPECT_EQ(s.reference_graph, 0);
  const FloorPlacement* p1 = s.placement(1);
  ASSERT_NE(p1, nullptr);
  EXPECT_TRUE(p1->aligned);
  const BuildingSummary summary = summarizeBuilding(building, s);
  EXPECT_EQ(summary.aligned_graphs, 2);
  EXPECT_EQ(summary.constraints, 3);
  EXPECT_TRUE(summary.warnings.empty());
  EXPECT_TRUE(summary.floors_to_check.empty());
  EXPECT_NEAR(p1->transform.x(), 3.0, 1e-6);
  EXPECT_NEAR(p1->transform.y(), -2.0, 1e-6);
  EXPECT_NEAR(p1->transform.theta(), 0.4, 1e-6);
  EXPECT_DOUBLE_EQ(p1->height, 3.0);
  EXPECT_LT(s.final_chi2, 1e-8);
}

TEST(BuildingGraph, UnconstrainedFloorIsNotAligned) {
  BuildingGraph building;
  building.upsertFloorGraph(makeLoop(0, 0, 0.0, Pose2(), nullptr));
  building.upsertFloorGraph(makeLoop(4, 1, 3.0, Pose2(), nullptr));
  const BuildingSolution s = building.optimize();
  EXPECT_TRUE(s.placement(0)->aligned);
  EXPECT_FALSE(s.placement(4)->aligned);
}

// One robot maps floor 0, rides a lift and maps floor 1, and no constraint joins them:
// floor 1 is not aligned, but it lies where the robot's odometry through the ride puts it
// (exact odometry here, in a frame of its own), not at the building's origin.
TEST(BuildingGraph, AnUnconstrainedFloorLiesWhereTheRobotsOdometryPutsIt) {
  const Pose2 frame1(3.0, -2.0, 0.4), odometry_frame(-7.0, 1.0, -1.1);
  std::vector<Pose2> truth0, truth1;
  floor::FloorGraph g0 = makeLoop(0, 0, 0.0, Pose2(), &truth0),
                    g1 = makeLoop(1, 1, 3.0, frame1, &truth1);
  for (auto* g : {&g0, &g1}) {
    g->robot = "r";
    const std::vector<Pose2>& truth = g == &g0 ? truth0 : truth1;
    for (std::size_t i = 0; i < g->nodes.size(); ++i) {
      g->nodes[i].stamp += g == &g0 ? 0.0 : 100.0;  // floor 1 after floor 0
      g->nodes[i].odometry = odometry_frame * truth[i];
    }
  }
  BuildingGraph building;
  building.upsertFloorGraph(g0);
  building.upsertFloorGraph(g1);
  const BuildingSolution s = building.optimize();
  const FloorPlacement* p1 = s.placement(1);
  ASSERT_NE(p1, nullptr);
  EXPECT_FALSE(p1->aligned);
  EXPECT_NEAR(p1->transform.x(), 3.0, 1e-6);
  EXPECT_NEAR(p1->transform.y(), -2.0, 1e-6);
  EXPECT_NEAR(p1->transform.theta(), 0.4, 1e-6);
  // Another robot's graph, with no floor change to a placed one, stays in its own frame.
  g1.robot = "s";
  BuildingGraph separate;
  separate.upsertFloorGraph(g0);
  separate.upsertFloorGraph(g1);
  EXPECT_NEAR(separate.optimize().placement(1)->transform.translation().norm(), 0.0, 1e-9);
  // The summary names the floor to check and how it was placed, each way.
  EXPECT_TRUE(s.placement(1)->placed_by_ride);
  const BuildingSummary by_ride = summarizeBuilding(building, s);
  EXPECT_EQ(by_ride.floors, 2);
  EXPECT_EQ(by_ride.robots, 1);
  EXPECT_EQ(by_ride.aligned_graphs, 1);
  EXPECT_EQ(by_ride.floors_to_check, std::vector<int>{1});
  ASSERT_EQ(by_ride.warnings.size(), 1u);
  EXPECT_NE(by_ride.warnings[0].find("through its ride"), std::string::npos) << by_ride.warnings[0];
  const BuildingSolution alone = separate.optimize();
  EXPECT_FALSE(alone.placement(1)->placed_by_ride);
  const BuildingSummary apart = summarizeBuilding(separate, alone);
  EXPECT_EQ(apart.robots, 2);
  ASSERT_EQ(apart.warnings.size(), 1u);
  EXPECT_NE(apart.warnings[0].find("own frame"), std::string::npos) << apart.warnings[0];
}

TEST(BuildingGraph, BadConstraintsAreRejectedWithTheirId) {
  BuildingGraph building;
  building.upsertFloorGraph(makeLoop(0, 0, 0.0, Pose2(), nullptr));
  building.upsertFloorGraph(makeLoop(1, 1, 3.0, Pose2(), nullptr));
  InterGraphConstraint c;
  c.id = 17;
  c.graph_from = 0;
  c.graph_to = 9;
  try {
    building.addConstraint(c);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("constraint 17"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("unknown floor graph 9"), std::string::npos);
  }
  c.graph_to = 1;
  c.node_to = 99;
  EXPECT_THROW(building.addConstraint(c), std::invalid_argument);
  c.node_to = 1;
  c.information(0, 0) = -1;
  EXPECT_THROW(building.addConstraint(c), std::invalid_argument);
  c.information = Eigen::Matrix3d::Identity();
  c.dz = std::nan("");
  EXPECT_THROW(building.addConstraint(c), std::invalid_argument);
  EXPECT_TRUE(building.constraints().empty());
}

// The building graph's solver without a file is the one config/graph_server.yaml sets.
TEST(BuildingGraphOptions, DefaultsEqualTheShippedFile) {
  const auto root =
      common::ConfigNode::loadFile(storey::test::sourceDir() + "/config/graph_server.yaml");
  const graph::OptimizerOptions f = readBuildingGraphOptions(root.child("building")).optimizer;
  const graph::OptimizerOptions d = BuildingGraphOptions().optimizer;
  EXPECT_EQ(f.algorithm, d.algorithm);
  EXPECT_EQ(f.max_iterations, d.max_iterations);
  for (int kind = 0; kind < graph::kEdgeKindCount; ++kind) {
    EXPECT_EQ(f.robust[kind].type, d.robust[kind].type) << kind;
    EXPECT_EQ(f.robust[kind].delta, d.robust[kind].delta) << kind;
  }
  EXPECT_EQ(d.robust[static_cast<int>(graph::EdgeKind::kInterFloor)].type,
            graph::RobustKernelType::kCauchy);
}

TEST(FitRigidTransform, RecoversKnownTransform) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-5, 5);
  const Pose2 t(1.5, -0.5, 2.5);
  std::vector<Pose2> local, global;
  for (int i = 0; i < 10; ++i) {
    local.emplace_back(u(rng), u(rng), u(rng));
    global.push_back(t * local.back());
  }
  const Pose2 fit = fitRigidTransform(local, global);
  EXPECT_NEAR(fit.x(), t.x(), 1e-9);
  EXPECT_NEAR(fit.y(), t.y(), 1e-9);
  EXPECT_NEAR(geometry::angleDiff(fit.theta(), t.theta()), 0.0, 1e-9);
  // One node: defined by its heading.
  const Pose2 single = fitRigidTransform({local[0]}, {global[0]});
  EXPECT_NEAR(single.x(), t.x(), 1e-9);
}

TEST(BuildingOutputs, OctomapHasOccupiedVoxelsOnEveryFloorAtTheRightHeight) {
  BuildingGraph building;
  building.upsertFloorGraph(makeLoop(0, 0, 0.0, Pose2(), nullptr));
  building.upsertFloorGraph(makeLoop(1, 1, 3.0, Pose2(), nullptr));
  const BuildingSolution s = building.optimize();
  grid::OccupancyGridOptions grid_options;
  grid_options.resolution = 0.05;
  const auto floors = renderBuildingFloors(building, s, grid_options);
  ASSERT_EQ(floors.size(), 2u);
  OctomapOptions options;
  options.resolution = 0.1;
  options.wall_height = 2.0;
  const std::string path = test::makeTempDir() + "/building.bt";
  const std::size_t occupied = writeBuildingOctomap(path, floors, options);
  EXPECT_GT(occupied, 100u);
  octomap::OcTree tree(path);
  ASSERT_GT(tree.size(), 0u);
  int low = 0, high = 0, between = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const double z = it.getZ();
    if (z > 0.0 && z < 2.0) ++low;
    else if (z > 3.0 && z < 5.0) ++high;
    else ++between;
  }
  EXPECT_GT(low, 50);
  EXPECT_GT(high, 50);
  EXPECT_EQ(between, 0);
  const grid::Image overlay = renderFloorOverlay(floors);
  EXPECT_GT(overlay.width, 10);
}

// The isometric view stacks the floors: the upper floor's walls are drawn above the
// lower floor's, and each constraint is a black line between them.
TEST(BuildingOutputs, IsometricViewStacksTheFloorsAndDrawsTheConstraints) {
  std::vector<Pose2> truth0, truth1;
  BuildingGraph building;
  building.upsertFloorGraph(makeLoop(0, 0, 0.0, Pose2(), &truth0));
  building.upsertFloorGraph(makeLoop(1, 1, 3.0, Pose2(), &truth1));
  int id = 0;
  for (int k : {1, 5, 9})
    building.addConstraint(exactConstraint(id++, 0, k, 1, k, truth0[k], truth1[k], 3.0));
  const BuildingSolution s = building.optimize();
  const auto floors = renderBuildingFloors(building, s, grid::OccupancyGridOptions());
  const grid::Image plain = renderIsometric(floors, 400);
  const grid::Image image = renderIsometric(floors, 400, &building, &s);
  ASSERT_EQ(image.width, 400);
  EXPECT_LE(image.height, 2 * image.width);
  // Mean row of each floor's colour, and the black pixels.
  const auto c0 = floorColour(0), c1 = floorColour(1);
  double rows[2] = {0, 0};
  int counts[2] = {0, 0}, black = 0, plain_black = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const std::uint8_t* p = image.at(x, y);
      const std::array<std::uint8_t, 3> rgb{p[0], p[1], p[2]};
      if (rgb == c0) rows[0] += y, ++counts[0];
      if (rgb == c1) rows[1] += y, ++counts[1];
      if (rgb == std::array<std::uint8_t, 3>{0, 0, 0}) ++black;
      const std::uint8_t* q = plain.at(x, y);
      if (q[0] == 0 && q[1] == 0 && q[2] == 0) ++plain_black;
    }
  ASSERT_GT(counts[0], 50);
  ASSERT_GT(counts[1], 50);
  EXPECT_GT(rows[0] / counts[0], rows[1] / counts[1] + 20);  // floor 1 higher up (smaller rows)
  EXPECT_GT(black, 20);
  EXPECT_EQ(plain_black, 0);
  // Without constraints: no black line, the path still drawn.
  const grid::Image unconstrained = renderIsometric(floors, 400, &building, &s, false);
  int path = 0;
  for (int y = 0; y < unconstrained.height; ++y)
    for (int x = 0; x < unconstrained.width; ++x) {
      const std::uint8_t* q = unconstrained.at(x, y);
      EXPECT_FALSE(q[0] == 0 && q[1] == 0 && q[2] == 0) << x << ", " << y;
      if (std::array<std::uint8_t, 3>{q[0], q[1], q[2]} == robotColour(0)) ++path;
    }
  EXPECT_GT(path, 20);
}

// Two floors 3 m apart, the upper one mapped after the lower (by robot "r", or by "s"
// when not `one_robot`), joined by three exact constraints, optimised.
struct TwoFloors {
  BuildingGraph building;
  BuildingSolution solution;
};
TwoFloors twoFloorsByRide(bool one_robot) {
  std::vector<Pose2> truth0, truth1;
  floor::FloorGraph lower = makeLoop(0, 0, 0.0, Pose2(), &truth0);
  floor::FloorGraph upper = makeLoop(1, 1, 3.0, Pose2(), &truth1);
  for (auto& n : upper.nodes) n.stamp += 100.0;  // after the lower floor's
  lower.robot = "r";
  upper.robot = one_robot ? "r" : "s";
  TwoFloors t;
  t.building.upsertFloorGraph(lower);
  t.building.upsertFloorGraph(upper);
  int id = 0;
  for (int k : {1, 5, 9})
    t.building.addConstraint(exactConstraint(id++, 0, k, 1, k, truth0[k], truth1[k], 3.0));
  t.solution = t.building.optimize();
  return t;
}

// One robot on two floors: its ride is a line in its colour from its last node on the
// first floor to its first on the second; the same graphs driven by two robots have the
// same paths and no ride.
TEST(BuildingOutputs, IsometricViewDrawsARobotsRideBetweenFloors) {
  auto pathPixels = [](bool one_robot) {
    const TwoFloors t = twoFloorsByRide(one_robot);
    const BuildingGraph& building = t.building;
    const BuildingSolution& s = t.solution;
    const grid::Image image = renderIsometric(
        renderBuildingFloors(building, s, grid::OccupancyGridOptions()), 400, &building, &s, false);
    int count = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const std::uint8_t* q = image.at(x, y);
        const std::array<std::uint8_t, 3> rgb{q[0], q[1], q[2]};
        if (rgb == robotColour(0) || rgb == robotColour(1)) ++count;
      }
    return count;
  };
  const int paths = pathPixels(false);
  EXPECT_GT(paths, 40);
  // The ride rises from (3, 2) on floor 0 to (0, 0) on floor 1: tens of pixels.
  EXPECT_GT(pathPixels(true), paths + 20);
}

// One robot on two floors, three constraints: the scene holds both floors' walls at their
// heights, a path per floor graph on its floor, one ride from floor 0 up to floor 1 and the
// constraints between the constrained nodes; without constraints asked for, none.
TEST(BuildingScene, HoldsWallsPathsTheRideAndTheConstraints) {
  const TwoFloors t = twoFloorsByRide(true);
  const BuildingGraph& building = t.building;
  const BuildingSolution& s = t.solution;
  const auto floors = renderBuildingFloors(building, s, grid::OccupancyGridOptions());
  const BuildingScene scene = buildingScene(floors, &building, &s);
  ASSERT_EQ(scene.floors.size(), 2u);
  EXPECT_EQ(scene.floors[0].floor_id, 0);
  EXPECT_EQ(scene.floors[1].height, 3.0);
  for (const SceneFloor& f : scene.floors) {
    EXPECT_GT(f.walls.size(), 20u);
    for (const Eigen::Vector2d& w : f.walls) {  // ring scans of 2 m around nodes in [0, 3] x [0, 2]
      EXPECT_GT(w.x(), f.x0);
      EXPECT_LT(w.y(), f.y1);
      EXPECT_LT(w.norm(), 6.5);
    }
  }
  ASSERT_EQ(scene.paths.size(), 2u);
  for (const SceneLine& path : scene.paths) {
    EXPECT_EQ(path.points.size(), 12u);
    for (const Eigen::Vector3d& p : path.points) EXPECT_EQ(p.z(), path.floor_id == 0 ? 0.0 : 3.0);
  }
  ASSERT_EQ(scene.rides.size(), 1u);
  // The last node below (3, 2) to the first above (0, 0).
  EXPECT_NEAR((scene.rides[0].points[0] - Eigen::Vector3d(3, 2, 0)).norm(), 0.0, 1e-6);
  EXPECT_NEAR((scene.rides[0].points[1] - Eigen::Vector3d(0, 0, 3)).norm(), 0.0, 1e-6);
  ASSERT_EQ(scene.constraints.size(), 3u);
  EXPECT_NEAR((scene.constraints[0].points[1] - scene.constraints[0].points[0]).norm(), 3.0, 1e-6);
  EXPECT_TRUE(buildingScene(floors, &building, &s, false).constraints.empty());
  EXPECT_TRUE(buildingScene(floors).paths.empty());
}

// Thinning keeps at most one wall point per square, doubles the square until the budget
// holds, and keeps every floor.
TEST(BuildingScene, ThinnedWallsStayWithinTheirBudget) {
  BuildingScene scene;
  for (int f = 0; f < 3; ++f) {
    SceneFloor floor;
    floor.floor_id = f;
    for (int i = 0; i < 1000; ++i) floor.walls.emplace_back(0.01 * i, 0.005 * f);  // a 10 m wall
    scene.floors.push_back(floor);
  }
  BuildingScene fine = scene;
  EXPECT_EQ(thinWalls(fine, 0.1, 100000), 0.1);
  for (const SceneFloor& f : fine.floors) EXPECT_EQ(f.walls.size(), 100u);
  const double cell = thinWalls(scene, 0.1, 100);
  EXPECT_EQ(cell, 0.4);  // 25 points a floor
  std::size_t total = 0;
  for (const SceneFloor& f : scene.floors) {
    EXPECT_GT(f.walls.size(), 0u);
    total += f.walls.size();
  }
  EXPECT_LE(total, 100u);
}

}  // namespace
}  // namespace storey::building
