#include <gtest/gtest.h>

#include <random>

#include "storey/graph/pose_graph.h"
#include "test_support.h"

namespace storey::graph {
namespace {

using geometry::Pose2;

TEST(EdgeResidual, IsZeroForAnExactMeasurement) {
  const Pose2 xi(1.0, -2.0, 0.3), xj(4.0, 0.5, -2.9);
  const Eigen::Vector3d e = edgeResidual(xi, xj, xi.between(xj));
  EXPECT_LT(e.norm(), 1e-12);
}

TEST(EdgeResidual, MatchesTheComposedTransform) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> pos(-10, 10), ang(-M_PI, M_PI);
  for (int k = 0; k < 1000; ++k) {
    const Pose2 xi(pos(rng), pos(rng), ang(rng)), xj(pos(rng), pos(rng), ang(rng)),
        z(pos(rng), pos(rng), ang(rng));
    const Pose2 expected = z.inverse() * xi.between(xj);
    const Eigen::Vector3d e = edgeResidual(xi, xj, z);
    EXPECT_NEAR(e.x(), expected.x(), 1e-9);
    EXPECT_NEAR(e.y(), expected.y(), 1e-9);
    EXPECT_NEAR(geometry::angleDiff(e.z(), expected.theta()), 0.0, 1e-9);
    EXPECT_GE(e.z(), -M_PI);
    EXPECT_LT(e.z(), M_PI);
  }
}

// Analytic Jacobians against central differences over thousands of random states.
TEST(EdgeResidual, JacobiansMatchNumericDerivatives) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> pos(-50, 50), ang(-M_PI, M_PI), small(-3, 3);
  int checked = 0;
  for (int k = 0; k < 5000; ++k) {
    const Eigen::Vector3d vi(pos(rng), pos(rng), ang(rng)), vj(pos(rng), pos(rng), ang(rng));
    const Pose2 z(small(rng), small(rng), ang(rng));
    Eigen::Matrix3d d_xi, d_xj;
    const Eigen::Vector3d e = edgeResidual(Pose2(vi), Pose2(vj), z, &d_xi, &d_xj);
    // Central differences straddling the ±π wrap of the angle residual are meaningless.
    if (std::abs(e.z()) > M_PI - 1e-3) continue;
    const Eigen::MatrixXd n_xi = test::numericJacobian(
        [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
          return edgeResidual(Pose2(v.x(), v.y(), v.z()), Pose2(vj), z);
        },
        vi);
    const Eigen::MatrixXd n_xj = test::numericJacobian(
        [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
          return edgeResidual(Pose2(vi), Pose2(v.x(), v.y(), v.z()), z);
        },
        vj);
    ASSERT_LT((n_xi - d_xi).cwiseAbs().maxCoeff(), 1e-5) << "state " << k << "\n" << d_xi;
    ASSERT_LT((n_xj - d_xj).cwiseAbs().maxCoeff(), 1e-5) << "state " << k << "\n" << d_xj;
    ++checked;
  }
  EXPECT_GT(checked, 4900);
}

TEST(InformationProblem, RejectsBadMatrices) {
  EXPECT_EQ(informationProblem(Eigen::Matrix3d::Identity()), "");
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(2, 2) = 0.0;
  EXPECT_NE(informationProblem(m).find("positive definite"), std::string::npos);
  m = Eigen::Matrix3d::Identity();
  m(0, 1) = 0.5;
  EXPECT_NE(informationProblem(m).find("symmetric"), std::string::npos);
  m = Eigen::Matrix3d::Identity();
  m(1, 1) = std::nan("");
  EXPECT_NE(informationProblem(m).find("finite"), std::string::npos);
  m = Eigen::Matrix3d::Identity();
  m(0, 1) = m(1, 0) = 2.0;  // symmetric but indefinite
  EXPECT_NE(informationProblem(m).find("positive definite"), std::string::npos);
}

}  // namespace
}  // namespace storey::graph
