#include "storey/building/building_markers.h"

#include <gtest/gtest.h>

#include "building_runs.h"

namespace storey::building {
namespace {

TEST(BuildingMarkers, FloorGraphsConstraintsAndLabelsInTheBuildingFrame) {
  const Pose2 frame1(3.0, -2.0, 0.4), odom(1.0, 2.0, 0.3);
  std::vector<Pose2> truth0, truth1, truth2;
  BuildingGraph building;
  building.upsertFloorGraph(makeRun("a", 0, 0, 0.0, 0.0, Pose2(), odom, &truth0));
  building.upsertFloorGraph(makeRun("a", 1, 1, 3.5, 100.0, frame1, odom, &truth1));
  // A third graph no constraint joins: drawn grey.
  building.upsertFloorGraph(makeRun("b", 2, 2, 7.0, 50.0, Pose2(), odom, &truth2));
  int id = 0;
  for (int k : {1, 3, 5})
    building.addConstraint(exactConstraint(id++, 0, k, 1, k, truth0[k], truth1[k], 3.5));
  const BuildingSolution solution = building.optimize();
  const auto markers = buildingMarkers(building, solution);
  // Three strips (graphs 0, 1, 2), one line list, three labels.
  ASSERT_EQ(markers.size(), 7u);
  for (int g = 0; g < 3; ++g) {
    const BuildingMarker& strip = markers[static_cast<std::size_t>(g)];
    EXPECT_EQ(strip.kind, BuildingMarker::Kind::kLineStrip);
    EXPECT_EQ(strip.ns, "floor_graphs");
    EXPECT_EQ(strip.id, g);
    ASSERT_EQ(strip.points.size(), 6u);
  }
  // Graph 1's nodes where the constraints put them, at its floor's height.
  for (std::size_t i = 0; i < 6; ++i) {
    const Eigen::Vector3d& p = markers[1].points[i];
    EXPECT_NEAR((p.head<2>() - truth1[i].translation()).norm(), 0.0, 1e-6) << i;
    EXPECT_NEAR(p.z(), 3.5, 1e-9);
  }
  EXPECT_NE(markers[0].rgba, markers[1].rgba);                                 // floors told apart
  EXPECT_EQ(markers[2].rgba, (std::array<float, 4>{0.6f, 0.6f, 0.6f, 1.0f}));  // not joined
  const BuildingMarker& lines = markers[3];
  EXPECT_EQ(lines.kind, BuildingMarker::Kind::kLineList);
  ASSERT_EQ(lines.points.size(), 6u);  // two ends per constraint
  EXPECT_NEAR((lines.points[0].head<2>() - truth0[1].translation()).norm(), 0.0, 1e-6);
  EXPECT_NEAR(lines.points[0].z(), 0.0, 1e-9);
  EXPECT_NEAR((lines.points[1].head<2>() - truth1[1].translation()).norm(), 0.0, 1e-6);
  EXPECT_NEAR(lines.points[1].z(), 3.5, 1e-9);
  for (int f = 0; f < 3; ++f) {
    const BuildingMarker& label = markers[4 + static_cast<std::size_t>(f)];
    EXPECT_EQ(label.kind, BuildingMarker::Kind::kText);
    EXPECT_EQ(label.id, f);
    EXPECT_EQ(label.text, "floor " + std::to_string(f));
  }
}

TEST(BuildingMarkers, AnEmptyBuildingHasNone) {
  EXPECT_TRUE(buildingMarkers(BuildingGraph(), BuildingSolution()).empty());
}

}  // namespace
}  // namespace storey::building
