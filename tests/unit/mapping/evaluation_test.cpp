// Edge consistency against reference poses (mapping/evaluation.h).
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "storey/mapping/evaluation.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;

TEST(EdgeConsistency, NormalisesEachKindsErrorByItsInformation) {
  floor::FloorGraph graph;
  const std::map<int, Pose2> truth = {{0, Pose2(0, 0, 0)}, {1, Pose2(1, 0, 0.5)}, {2, Pose2(1, 1, 1.0)}};
  auto edge = [&](int from, int to, const Pose2& error, double sigma, floor::EdgeKind kind) {
    floor::FloorEdge e;
    e.from = from;
    e.to = to;
    e.measurement = truth.at(from).between(truth.at(to)) * error;
    e.information = Eigen::Vector3d(1 / (sigma * sigma), 1 / (sigma * sigma), 1 / (sigma * sigma)).asDiagonal();
    e.kind = kind;
    graph.edges.push_back(e);
  };
  edge(0, 1, Pose2(0.02, 0.0, 0.0), 0.01, floor::EdgeKind::kScanMatch);  // NEES 4
  edge(1, 2, Pose2(0.0, 0.0, 0.03), 0.01, floor::EdgeKind::kScanMatch);  // NEES 9
  edge(0, 1, Pose2(0.0, 0.1, 0.0), 0.1, floor::EdgeKind::kOdometry);     // NEES 1
  floor::FloorEdge unknown;  // node 5 has no reference pose: left out
  unknown.from = 0;
  unknown.to = 5;
  unknown.kind = floor::EdgeKind::kLoopClosure;
  graph.edges.push_back(unknown);
  const auto result = edgeConsistency(graph, truth);
  ASSERT_EQ(result.size(), 2u);
  EXPECT_EQ(result[0].kind, floor::EdgeKind::kOdometry);
  EXPECT_EQ(result[0].count, 1u);
  EXPECT_NEAR(result[0].mean_nees, 1.0, 1e-9);
  EXPECT_NEAR(result[0].rms_translation_error, 0.1 / std::sqrt(2.0), 1e-9);  // per axis
  EXPECT_NEAR(result[0].rms_translation_sigma, 0.1, 1e-9);
  EXPECT_EQ(result[1].kind, floor::EdgeKind::kScanMatch);
  EXPECT_EQ(result[1].count, 2u);
  EXPECT_NEAR(result[1].mean_nees, 6.5, 1e-9);
  EXPECT_NEAR(result[1].rms_rotation_error, 0.03 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(result[1].rms_rotation_sigma, 0.01, 1e-9);
}

}  // namespace
}  // namespace storey::mapping
