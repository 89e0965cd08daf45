#include "storey/mapping/closure_clusters.h"

#include <gtest/gtest.h>

#include <random>

namespace storey::mapping {
namespace {

using geometry::Pose2;

Pose2 randomPose(std::mt19937& rng, double extent = 5.0) {
  std::uniform_real_distribution<double> xy(-extent, extent), angle(-M_PI, M_PI);
  return Pose2(xy(rng), xy(rng), angle(rng));
}

Pose2 perturbed(const Pose2& p, int axis, double h) {
  Eigen::Vector3d v = p.vector();
  v[axis] += h;
  return Pose2(v);
}

TEST(ClosureCycle, JacobiansMatchNumericDerivatives) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    std::array<Pose2, 4> poses{randomPose(rng), randomPose(rng), randomPose(rng), randomPose(rng)};
    std::array<Eigen::Matrix3d, 4> analytic;
    const Eigen::Vector3d e0 = closureCycleError(poses[0], poses[1], poses[2], poses[3], &analytic);
    if (std::abs(e0.z()) > M_PI - 0.01) continue;  // the wrap makes the derivative jump
    for (int which = 0; which < 4; ++which)
      for (int axis = 0; axis < 3; ++axis) {
        const double h = 1e-6;
        auto plus = poses, minus = poses;
        plus[which] = perturbed(poses[which], axis, h);
        minus[which] = perturbed(poses[which], axis, -h);
        Eigen::Vector3d d = closureCycleError(plus[0], plus[1], plus[2], plus[3]) -
                            closureCycleError(minus[0], minus[1], minus[2], minus[3]);
        d.z() = geometry::normalizeAngle(d.z());
        const Eigen::Vector3d numeric = d / (2 * h);
        EXPECT_LT((numeric - analytic[which].col(axis)).norm(), 1e-5)
            << "pose " << which << " axis " << axis << " trial " << trial;
      }
  }
}

// Two closures of a robot that passes a place it saw before: old nodes a_i, a_j, new ones
// b_i, b_j, each closure z = x_a⁻¹ x_b.
struct TwoClosures {
  Pose2 a_i{0, 0, 0.1}, a_j{2, 0.1, 0.15}, b_i{0.3, 0.2, 3.0}, b_j{-1.6, 0.4, 3.1};
  Pose2 z_i() const { return a_i.between(b_i); }
  Pose2 z_j() const { return a_j.between(b_j); }
};

TEST(ClosureCycle, RightClosuresCloseTheCycle) {
  const TwoClosures c;
  const Eigen::Vector3d e = closureCycleError(c.a_i.between(c.a_j), c.z_i(), c.b_i.between(c.b_j), c.z_j());
  EXPECT_LT(e.norm(), 1e-12);
}

TEST(ClosureCycle, PairChi2TellsAgreeingFromShiftedClosures) {
  const TwoClosures c;
  const Eigen::Matrix3d match = Eigen::Vector3d(0.05 * 0.05, 0.05 * 0.05, 0.01 * 0.01).asDiagonal();
  const Eigen::Matrix3d chain = Eigen::Vector3d(0.03 * 0.03, 0.03 * 0.03, 0.005 * 0.005).asDiagonal();
  const UncertainPose old{c.a_i.between(c.a_j), chain}, recent{c.b_i.between(c.b_j), chain};
  // Measurement noise of about one sigma: agrees.
  const Pose2 z_j_noisy = c.z_j() * Pose2(0.04, -0.03, 0.008);
  EXPECT_LT(closurePairChi2(old, {c.z_i(), match}, recent, {z_j_noisy, match}), 11.34);
  // The second closure one door (2 m) further along the old corridor: disagrees.
  const Pose2 z_j_shifted = Pose2(2.0, 0, 0) * c.z_j();
  EXPECT_GT(closurePairChi2(old, {c.z_i(), match}, recent, {z_j_shifted, match}), 100.0);
  // The same shift claimed only as a weak direction (along x of a_j, σ 5 m): no longer refused.
  Eigen::Matrix3d weak_along_x = match;
  weak_along_x(0, 0) = 25.0;
  EXPECT_LT(closurePairChi2(old, {c.z_i(), match}, recent, {z_j_shifted, weak_along_x}), 11.34);
  // A singular propagated covariance cannot agree with anything.
  EXPECT_TRUE(std::isinf(closurePairChi2({old.pose, Eigen::Matrix3d::Zero()}, {c.z_i(), Eigen::Matrix3d::Zero()},
                                         {recent.pose, Eigen::Matrix3d::Zero()}, {z_j_noisy, Eigen::Matrix3d::Zero()})));
}

TEST(ClosureCycle, PairChi2FollowsTheChiSquareDistribution) {
  // Closures drawn with the claimed noise: about 1 % of pairs above χ²(3) at 99 %.
  const TwoClosures c;
  std::mt19937 rng(9);
  std::normal_distribution<double> unit;
  const Eigen::Vector3d sigma(0.05, 0.08, 0.02);
  const Eigen::Matrix3d covariance = sigma.cwiseProduct(sigma).asDiagonal();
  auto noisy = [&](const Pose2& p) { return p * Pose2(sigma.x() * unit(rng), sigma.y() * unit(rng), sigma.z() * unit(rng)); };
  int above = 0;
  const int trials = 4000;
  double sum = 0.0;
  for (int t = 0; t < trials; ++t) {
    const double chi2 = closurePairChi2({noisy(c.a_i.between(c.a_j)), covariance}, {noisy(c.z_i()), covariance},
                                        {noisy(c.b_i.between(c.b_j)), covariance}, {noisy(c.z_j()), covariance});
    sum += chi2;
    above += chi2 > 11.34 ? 1 : 0;
  }
  EXPECT_NEAR(sum / trials, 3.0, 0.3);  // mean of χ²(3), to first order
  EXPECT_LT(above, trials * 3 / 100);
}

TEST(ClosureChain, ComposesPosesAndCovariances) {
  const std::vector<Pose2> poses{{1, 1, 0.2}, {2, 1.3, 0.4}, {2.5, 2.5, 1.2}, {2, 3, 2.0}};
  const Eigen::Matrix3d step = Eigen::Vector3d(0.01, 0.02, 0.001).asDiagonal();
  std::vector<UncertainPose> steps;
  for (std::size_t k = 0; k + 1 < poses.size(); ++k) steps.push_back({poses[k].between(poses[k + 1]), step});
  const UncertainPose chain = composeChain(steps);
  const Pose2 expected = poses.front().between(poses.back());
  EXPECT_LT((chain.pose.vector() - expected.vector()).norm(), 1e-12);
  // Step by step by hand.
  Eigen::Matrix3d covariance = step;
  covariance = geometry::composeCovariance(poses[0].between(poses[1]), covariance, poses[1].between(poses[2]), step);
  covariance = geometry::composeCovariance(poses[0].between(poses[2]), covariance, poses[2].between(poses[3]), step);
  EXPECT_LT((chain.covariance - covariance).norm(), 1e-12);
  // No steps: the identity, certain.
  const UncertainPose none = composeChain({});
  EXPECT_LT(none.pose.vector().norm(), 1e-12);
  EXPECT_EQ(none.covariance, Eigen::Matrix3d::Zero());
}

std::vector<std::vector<char>> randomGraph(std::mt19937& rng, int n, double density) {
  std::bernoulli_distribution edge(density);
  std::vector<std::vector<char>> adjacent(n, std::vector<char>(n, 0));
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) adjacent[i][j] = adjacent[j][i] = edge(rng) ? 1 : 0;
  return adjacent;
}

// The largest clique containing `must`, by trying every subset (n <= 14).
std::size_t bruteForceClique(const std::vector<std::vector<char>>& adjacent, int must) {
  const int n = static_cast<int>(adjacent.size());
  std::size_t best = 0;
  for (unsigned mask = 0; mask < (1u << n); ++mask) {
    if (!(mask >> must & 1u)) continue;
    bool clique = true;
    for (int i = 0; i < n && clique; ++i)
      for (int j = i + 1; j < n && clique; ++j)
        if ((mask >> i & 1u) && (mask >> j & 1u) && !adjacent[i][j]) clique = false;
    if (clique) best = std::max<std::size_t>(best, __builtin_popcount(mask));
  }
  return best;
}

TEST(ClosureClique, LargestCliqueContainingAVertexIsExact) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 60; ++trial) {
    const int n = 4 + trial % 11;
    const auto adjacent = randomGraph(rng, n, trial % 3 == 0 ? 0.8 : 0.5);
    const int must = trial % n;
    const std::vector<int> clique = largestCliqueContaining(adjacent, must);
    EXPECT_EQ(clique.size(), bruteForceClique(adjacent, must)) << "trial " << trial;
    EXPECT_TRUE(std::find(clique.begin(), clique.end(), must) != clique.end());
    for (int a : clique)
      for (int b : clique)
        if (a != b) {
          EXPECT_TRUE(adjacent[a][b]);
        }
  }
}

TEST(ClosureClique, TwoGroupsOfClosures) {
  // Vertices 0-3 agree with each other, 4-5 agree with each other and with 0 only.
  std::vector<std::vector<char>> adjacent(6, std::vector<char>(6, 0));
  auto join = [&](int a, int b) { adjacent[a][b] = adjacent[b][a] = 1; };
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) join(a, b);
  join(4, 5);
  join(0, 4);
  join(0, 5);
  EXPECT_EQ(largestCliqueContaining(adjacent, 2), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(largestCliqueContaining(adjacent, 5), (std::vector<int>{0, 4, 5}));
  const std::vector<std::vector<char>> alone(1, std::vector<char>(1, 0));
  EXPECT_EQ(largestCliqueContaining(alone, 0), (std::vector<int>{0}));
  EXPECT_THROW(largestCliqueContaining(alone, 1), std::out_of_range);
}

}  // namespace
}  // namespace storey::mapping
