#include "storey/geometry/pose2.h"

#include <gtest/gtest.h>

#include <random>

#include "test_support.h"

namespace storey::geometry {
namespace {

Pose2 randomPose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> pos(-20.0, 20.0), ang(-M_PI, M_PI);
  return Pose2(pos(rng), pos(rng), ang(rng));
}

void expectNear(const Pose2& a, const Pose2& b, double tol = 1e-9) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(angleDiff(a.theta(), b.theta()), 0.0, tol);
}

TEST(NormalizeAngle, WrapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(normalizeAngle(0.5), 0.5);
  EXPECT_NEAR(normalizeAngle(3 * M_PI), -M_PI, 1e-12);
  EXPECT_NEAR(normalizeAngle(-3 * M_PI / 2), M_PI / 2, 1e-12);
  EXPECT_NEAR(normalizeAngle(100.0), std::remainder(100.0, 2 * M_PI), 1e-9);
  for (double a = -50; a < 50; a += 0.37) {
    const double n = normalizeAngle(a);
    EXPECT_GE(n, -M_PI);
    EXPECT_LT(n, M_PI);
    EXPECT_NEAR(std::sin(n), std::sin(a), 1e-9);
    EXPECT_NEAR(std::cos(n), std::cos(a), 1e-9);
  }
}

TEST(Pose2, ComposeMatchesMatrices) {
  std::mt19937_64 rng(1);
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = randomPose(rng), b = randomPose(rng);
    const Eigen::Matrix3d m = a.matrix() * b.matrix();
    const Pose2 c = a * b;
    EXPECT_TRUE(c.matrix().isApprox(m, 1e-9));
  }
}

TEST(Pose2, InverseAndBetween) {
  std::mt19937_64 rng(2);
  for (int i = 0; i < 100; ++i) {
    const Pose2 a = randomPose(rng), b = randomPose(rng);
    expectNear(a * a.inverse(), Pose2());
    expectNear(a * a.between(b), b);
    const Eigen::Vector2d p(1.5, -2.0);
    EXPECT_TRUE(a.inverseTransformPoint(a.transformPoint(p)).isApprox(p, 1e-9));
  }
}

TEST(Pose2, Interpolate) {
  const Pose2 a(0, 0, M_PI - 0.1), b(2, 4, -M_PI + 0.1);
  expectNear(interpolate(a, b, 0.0), a);
  expectNear(interpolate(a, b, 1.0), b);
  const Pose2 mid = interpolate(a, b, 0.5);
  EXPECT_NEAR(mid.x(), 1.0, 1e-12);
  EXPECT_NEAR(mid.y(), 2.0, 1e-12);
  EXPECT_NEAR(std::abs(mid.theta()), M_PI, 1e-9);  // shortest arc crosses +-pi
}

TEST(Pose2, ComposeJacobiansMatchNumeric) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 a = randomPose(rng), b = randomPose(rng);
    Eigen::Matrix3d ja, jb;
    composeJacobians(a, b, &ja, &jb);
    const Pose2 c = a * b;
    auto wrt_a = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      const Pose2 r = Pose2(v) * b;
      return Eigen::Vector3d(r.x(), r.y(), c.theta() + angleDiff(r.theta(), c.theta()));
    };
    auto wrt_b = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      const Pose2 r = a * Pose2(v);
      return Eigen::Vector3d(r.x(), r.y(), c.theta() + angleDiff(r.theta(), c.theta()));
    };
    EXPECT_TRUE(ja.isApprox(test::numericJacobian(wrt_a, a.vector()), 1e-5));
    EXPECT_TRUE(jb.isApprox(test::numericJacobian(wrt_b, b.vector()), 1e-5));
  }
}

TEST(Pose2, InverseJacobianMatchesNumeric) {
  std::mt19937_64 rng(4);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 a = randomPose(rng);
    const Pose2 inv = a.inverse();
    auto f = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      const Pose2 r = Pose2(v).inverse();
      return Eigen::Vector3d(r.x(), r.y(), inv.theta() + angleDiff(r.theta(), inv.theta()));
    };
    EXPECT_TRUE(inverseJacobian(a).isApprox(test::numericJacobian(f, a.vector()), 1e-5));
  }
}

TEST(Pose2, CovariancePropagationMatchesSampling) {
  // Monte Carlo check of first-order propagation for small noise.
  const Pose2 a(1, 2, 0.3), b(3, -1, 0.7);
  Eigen::Matrix3d cov_a = Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal();
  Eigen::Matrix3d cov_b = Eigen::Vector3d(0.03, 0.01, 0.002).asDiagonal();
  const Eigen::Matrix3d predicted = composeCovariance(a, cov_a, b, cov_b);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  const int kSamples = 200000;
  Eigen::Matrix3d sampled = Eigen::Matrix3d::Zero();
  const Pose2 c = a * b;
  for (int i = 0; i < kSamples; ++i) {
    Eigen::Vector3d da(n(rng), n(rng), n(rng)), db(n(rng), n(rng), n(rng));
    da = da.cwiseProduct(cov_a.diagonal().cwiseSqrt());
    db = db.cwiseProduct(cov_b.diagonal().cwiseSqrt());
    const Pose2 r = Pose2(a.vector() + da) * Pose2(b.vector() + db);
    const Eigen::Vector3d d(r.x() - c.x(), r.y() - c.y(), angleDiff(r.theta(), c.theta()));
    sampled += d * d.transpose();
  }
  sampled /= kSamples;
  EXPECT_TRUE(sampled.isApprox(predicted, 0.05)) << sampled << "\n\n" << predicted;
}

TEST(Pose2, TransformPointsEqualsEachPointTransformed) {
  const Pose2 pose(1.5, -2.0, 2.7);
  const std::vector<Eigen::Vector2d> points = {{0.0, 0.0}, {1.0, 0.0}, {-3.25, 7.5}, {1e3, -1e-3}};
  const std::vector<Eigen::Vector2d> moved = pose.transformPoints(points);
  ASSERT_EQ(moved.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(moved[i].x(), pose.transformPoint(points[i]).x());  // the same bits: one formula
    EXPECT_EQ(moved[i].y(), pose.transformPoint(points[i]).y());
  }
  EXPECT_TRUE(pose.transformPoints({}).empty());
  // Into a buffer, and in place.
  std::vector<Eigen::Vector2d> in_place = points;
  pose.transformPoints(in_place, &in_place);
  EXPECT_EQ(in_place, moved);
}

}  // namespace
}  // namespace storey::geometry
