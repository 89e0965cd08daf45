#include "storey/graph/pose_graph.h"

#include <gtest/gtest.h>

#include "synthetic_graph.h"

namespace storey::graph {
namespace {

using geometry::Pose2;

TEST(PoseGraph, RejectsInvalidContent) {
  PoseGraph g;
  g.addNode(1, Pose2(0, 0, 0));
  g.addNode(2, Pose2(1, 0, 0));
  EXPECT_THROW(g.addNode(1, Pose2()), GraphError);
  EXPECT_THROW(g.addNode(3, Pose2(std::nan(""), 0, 0)), GraphError);
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  EXPECT_THROW(g.addEdge(1, 7, Pose2(), info), GraphError);
  EXPECT_THROW(g.addEdge(1, 1, Pose2(), info), GraphError);
  EXPECT_THROW(g.addEdge(1, 2, Pose2(std::nan(""), 0, 0), info), GraphError);
  Eigen::Matrix3d bad = info;
  bad(2, 2) = -1.0;
  try {
    g.addEdge(1, 2, Pose2(), bad);
    FAIL() << "non-positive-definite information accepted";
  } catch (const GraphError& error) {
    EXPECT_NE(std::string(error.what()).find("edge 1 -> 2"), std::string::npos) << error.what();
  }
  EXPECT_EQ(g.numEdges(), 0u);
  EXPECT_EQ(g.addEdge(1, 2, Pose2(1, 0, 0), info), 0u);
}

TEST(PoseGraph, StructureVersionTracksStructureOnly) {
  PoseGraph g;
  g.addNode(0, Pose2());
  g.addNode(1, Pose2());
  const auto v0 = g.structureVersion();
  g.addEdge(0, 1, Pose2(1, 0, 0), Eigen::Matrix3d::Identity());
  const auto v1 = g.structureVersion();
  EXPECT_NE(v0, v1);
  g.setPose(1, Pose2(3, 0, 0));
  g.setEdgeEnabled(0, false);
  EXPECT_EQ(g.structureVersion(), v1);
  g.setFixed(0, true);
  EXPECT_NE(g.structureVersion(), v1);
  PoseGraph other;
  EXPECT_NE(other.structureVersion(), g.structureVersion());
}

TEST(PoseGraph, ConnectedComponentsFollowEnabledEdges) {
  PoseGraph g;
  for (int k = 0; k < 5; ++k) g.addNode(k, Pose2());
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  g.addEdge(0, 1, Pose2(), info);
  const std::size_t e12 = g.addEdge(1, 2, Pose2(), info);
  g.addEdge(3, 4, Pose2(), info);
  int count = 0;
  std::vector<int> c = g.connectedComponents(&count);
  EXPECT_EQ(count, 2);
  EXPECT_EQ(c[0], c[2]);
  EXPECT_NE(c[0], c[3]);
  g.setEdgeEnabled(e12, false);
  c = g.connectedComponents(&count);
  EXPECT_EQ(count, 3);
  EXPECT_NE(c[0], c[2]);
}

TEST(InitializeFromOdometry, ChainsOdometryBeforeLoopClosures) {
  PoseGraph g;
  for (int k = 0; k < 4; ++k) g.addNode(k, Pose2());
  const Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  g.addEdge(0, 1, Pose2(1, 0, M_PI / 2), info, EdgeKind::kOdometry);
  g.addEdge(1, 2, Pose2(1, 0, 0), info, EdgeKind::kOdometry);
  // A (wrong) loop closure straight from 0 to 2 must not be used while odometry reaches 2.
  g.addEdge(0, 2, Pose2(5, 5, 0), info, EdgeKind::kLoopClosure);
  // Node 3 is reachable only through a backwards edge 3 -> 2.
  g.addEdge(3, 2, Pose2(0, 1, 0), info, EdgeKind::kLoopClosure);
  EXPECT_EQ(initializeFromOdometry(g), 4u);
  EXPECT_NEAR(g.node(1).pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(g.node(2).pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(g.node(2).pose.y(), 1.0, 1e-12);
  const Pose2 back = g.node(3).pose * Pose2(0, 1, 0);
  EXPECT_NEAR(back.x(), g.node(2).pose.x(), 1e-12);
  EXPECT_NEAR(back.y(), g.node(2).pose.y(), 1e-12);
}

TEST(PoseGraph, Chi2AtTheTruthFollowsTheNoiseModel) {
  // At the true poses each edge's χ² is chi-square with 3 degrees of freedom.
  testing::Synthetic s = testing::makeLaps(4, 10, 0.1, 0.01, 1);
  for (std::size_t i = 0; i < s.truth.size(); ++i) s.graph.setPoseAt(i, s.truth[i]);
  const double dof = 3.0 * s.graph.numEdges();
  EXPECT_NEAR(s.graph.chi2(), dof, 4.0 * std::sqrt(2.0 * dof));
  EXPECT_GT(std::abs(s.graph.chi2() - dof), 0.0);
  EXPECT_EQ(parseEdgeKind("loop_closure"), EdgeKind::kLoopClosure);
  EXPECT_THROW(parseEdgeKind("loop"), std::invalid_argument);
}

}  // namespace
}  // namespace storey::graph
