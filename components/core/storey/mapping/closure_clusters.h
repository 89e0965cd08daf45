// Loop-closure hypotheses judged by their agreement with each other.
//
// A loop closure found after a long loop disagrees with the graph by the drift it is meant
// to remove, so "does the optimised graph agree with it" rejects right closures exactly
// when they matter (infinite-corridor: 89 of 124 matched closures refused so, nearly all
// within 0.1 m of the truth). Two closures i and j (older node a, newer node b each) can
// instead be checked against each other through the short chains between their newer nodes
// and between their older ones: the cycle
//
//   b_i → a_i → a_j → b_j → b_i
//
// is the identity when both are right. A wrong closure (a similar room, a repeating door)
// is seldom consistent with another one made a few metres later. A set of closures that
// agree pairwise (a clique of the consistency graph) is evidence no single match gives.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "storey/geometry/pose2.h"

namespace storey::mapping {

// A relative pose with the covariance of its (x, y, θ) parameters.
struct UncertainPose {
  geometry::Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

// Error of closure z_j (a_j → b_j) against its prediction from closure z_i (a_i → b_i):
// old = x_{a_i}⁻¹ x_{a_j}, recent = x_{b_i}⁻¹ x_{b_j}, prediction = old⁻¹ · z_i · recent,
// error = toVector(z_j⁻¹ · prediction) with θ wrapped. `jacobians`, when given, receives
// the error's Jacobians with respect to (old, z_i, recent, z_j) in that order.
Eigen::Vector3d closureCycleError(const geometry::Pose2& old, const geometry::Pose2& z_i,
                                  const geometry::Pose2& recent, const geometry::Pose2& z_j,
                                  std::array<Eigen::Matrix3d, 4>* jacobians = nullptr);

// Mahalanobis χ² of that error, the four taken independent (first-order propagation).
// Infinity when the propagated covariance is singular.
double closurePairChi2(const UncertainPose& old, const UncertainPose& z_i, const UncertainPose& recent,
                       const UncertainPose& z_j);

// The steps composed in order (each in the frame the previous one ends in), with the
// covariance propagated to first order, the steps taken independent. No steps: the
// identity, certain.
UncertainPose composeChain(const std::vector<UncertainPose>& steps);

// The largest set of mutually adjacent vertices that contains `must` (ties: the one found
// first, vertices in index order). `adjacent` is symmetric; the diagonal is ignored.
// Exact (Bron–Kerbosch with pivoting): for the few tens of hypotheses a window holds.
std::vector<int> largestCliqueContaining(const std::vector<std::vector<char>>& adjacent, int must);

}  // namespace storey::mapping
