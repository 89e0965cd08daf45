#include "storey/graph/initialization.h"

#include <gtest/gtest.h>

#include "storey/graph/optimizer.h"
#include "synthetic_graph.h"

namespace storey::graph {
namespace {

using geometry::Pose2;

double maxError(const PoseGraph& g, const std::vector<Pose2>& truth, double* max_angle) {
  double worst = 0.0;
  *max_angle = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Pose2& p = g.nodes()[i].pose;
    worst = std::max(worst, (p.translation() - truth[i].translation()).norm());
    *max_angle = std::max(*max_angle, std::abs(geometry::angleDiff(p.theta(), truth[i].theta())));
  }
  return worst;
}

TEST(OrientationFirst, ExactOnNoiseFreeMeasurementsAcrossManyTurns) {
  // Five laps: the tree orientations reach 10π, so loop closures (measured rotation ≈ 0)
  // need 2π corrections.
  const testing::Synthetic s = testing::makeLaps(5, 4, 0.01, 0.01, 1);
  PoseGraph g;  // same graph with the true measurements, every free pose far off
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    g.addNode(s.graph.nodes()[i].id, i == 0 ? s.truth[0] : Pose2(7, -3, 2));
  }
  for (std::size_t e = 0; e < s.graph.numEdges(); ++e) {
    const std::size_t i = s.graph.edgeFromIndex(e), j = s.graph.edgeToIndex(e);
    g.addEdge(s.graph.nodes()[i].id, s.graph.nodes()[j].id, s.truth[i].between(s.truth[j]),
              s.graph.edges()[e].information, s.graph.edges()[e].kind);
  }
  const OrientationFirstInfo info = initializeOrientationFirst(g);
  EXPECT_EQ(info.nodes, g.numNodes() - 1);
  EXPECT_GT(info.wrapped_edges, 0u);
  double angle = 0.0;
  EXPECT_LT(maxError(g, s.truth, &angle), 1e-9);
  EXPECT_LT(angle, 1e-9);
  EXPECT_LT(g.chi2(), 1e-12);
}

TEST(OrientationFirst, StartsNearTheOptimumFromAPoorGuess) {
  // Large rotation noise: chained odometry is far off; the estimate is close to the optimum.
  const testing::Synthetic s = testing::makeLaps(4, 8, 0.05, 0.05, 3);
  PoseGraph optimum = s.graph;
  OptimizerOptions tight;
  tight.relative_chi2_tolerance = 1e-12;
  tight.max_iterations = 500;
  ASSERT_TRUE(Optimizer(tight).optimize(optimum).converged);
  PoseGraph g = s.graph;
  const double odometry_chi2 = g.chi2();
  initializeOrientationFirst(g);
  EXPECT_LT(g.chi2(), 0.05 * odometry_chi2);
  EXPECT_LT(g.chi2(), 2.0 * optimum.chi2());
  // And the optimiser from there reaches the same optimum in fewer steps.
  OptimizerOptions options;
  options.initialization = Initialization::kOrientationFirst;
  PoseGraph a = s.graph, b = s.graph;
  const OptimizerResult ra = Optimizer(options).optimize(a);
  const OptimizerResult rb = Optimizer().optimize(b);
  EXPECT_TRUE(ra.initialized);
  EXPECT_NEAR(ra.initial_chi2, odometry_chi2, 1e-9 * odometry_chi2);
  EXPECT_LT(ra.initialized_chi2, ra.initial_chi2);
  EXPECT_NEAR(ra.final_chi2, optimum.chi2(), 1e-6 * optimum.chi2());
  EXPECT_LE(ra.factorizations, rb.factorizations);
}

TEST(OrientationFirst, KeepsFixedNodesAndAnchorsEachComponent) {
  PoseGraph g;
  Eigen::Matrix3d info = Eigen::Matrix3d::Identity();
  info(0, 1) = info(1, 0) = 0.3;  // correlated: weights come from the covariance
  g.addNode(0, Pose2(0, 0, 0));
  g.addNode(1, Pose2(5, 5, 1));
  g.addNode(2, Pose2(1, 1, 1), /*fixed=*/true);
  g.addNode(10, Pose2(3, 4, 0.5));  // second component, no fixed node: its first is the anchor
  g.addNode(11, Pose2(0, 0, 0));
  g.addEdge(0, 1, Pose2(1, 0, M_PI / 2), info);
  g.addEdge(1, 2, Pose2(1, 0, 0), info);
  g.addEdge(10, 11, Pose2(2, 0, -0.5), info);
  initializeOrientationFirst(g);
  EXPECT_EQ(g.node(2).pose.vector(), Pose2(1, 1, 1).vector());
  EXPECT_EQ(g.node(10).pose.vector(), Pose2(3, 4, 0.5).vector());
  // Consistent measurements are met exactly.
  EXPECT_LT(g.chi2(), 1e-12);
  EXPECT_NEAR(g.node(11).pose.theta(), 0.0, 1e-12);
  EXPECT_NEAR(g.node(11).pose.x(), 3 + 2 * std::cos(0.5), 1e-12);
}

TEST(OrientationFirst, AutoRunsOnlyForPoorStartsWithoutRobustKernels) {
  const testing::Synthetic s = testing::makeLaps(3, 6, 0.05, 0.05, 5);
  OptimizerOptions options;
  options.initialization = Initialization::kAuto;
  PoseGraph poor = s.graph;
  EXPECT_TRUE(Optimizer(options).optimize(poor).initialized);
  PoseGraph good = poor;  // now at the optimum
  EXPECT_FALSE(Optimizer(options).optimize(good).initialized);
  options.robust[static_cast<int>(EdgeKind::kLoopClosure)] = {RobustKernelType::kDcs, 1.0};
  PoseGraph robust = s.graph;
  EXPECT_FALSE(Optimizer(options).optimize(robust).initialized);
}

}  // namespace
}  // namespace storey::graph
