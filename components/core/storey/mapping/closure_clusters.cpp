#include "storey/mapping/closure_clusters.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <limits>
#include <stdexcept>

namespace storey::mapping {

using geometry::Pose2;

Eigen::Vector3d closureCycleError(const Pose2& old, const Pose2& z_i, const Pose2& recent, const Pose2& z_j,
                                  std::array<Eigen::Matrix3d, 4>* jacobians) {
  const Pose2 old_inverse = old.inverse();
  const Pose2 via_i = old_inverse * z_i;
  const Pose2 prediction = via_i * recent;
  const Pose2 z_j_inverse = z_j.inverse();
  const Pose2 error = z_j_inverse * prediction;
  if (jacobians) {
    Eigen::Matrix3d d_via_old_inverse, d_via_z_i, d_prediction_via, d_prediction_recent, d_error_z_j_inverse,
        d_error_prediction;
    geometry::composeJacobians(old_inverse, z_i, &d_via_old_inverse, &d_via_z_i);
    geometry::composeJacobians(via_i, recent, &d_prediction_via, &d_prediction_recent);
    geometry::composeJacobians(z_j_inverse, prediction, &d_error_z_j_inverse, &d_error_prediction);
    const Eigen::Matrix3d d_error_via = d_error_prediction * d_prediction_via;
    (*jacobians)[0] = d_error_via * d_via_old_inverse * geometry::inverseJacobian(old);
    (*jacobians)[1] = d_error_via * d_via_z_i;
    (*jacobians)[2] = d_error_prediction * d_prediction_recent;
    (*jacobians)[3] = d_error_z_j_inverse * geometry::inverseJacobian(z_j);
  }
  return error.vector();
}

double closurePairChi2(const UncertainPose& old, const UncertainPose& z_i, const UncertainPose& recent,
                       const UncertainPose& z_j) {
  std::array<Eigen::Matrix3d, 4> j;
  const Eigen::Vector3d e = closureCycleError(old.pose, z_i.pose, recent.pose, z_j.pose, &j);
  const Eigen::Matrix3d covariance = j[0] * old.covariance * j[0].transpose() +
                                     j[1] * z_i.covariance * j[1].transpose() +
                                     j[2] * recent.covariance * j[2].transpose() +
                                     j[3] * z_j.covariance * j[3].transpose();
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(0.5 * (covariance + covariance.transpose()));
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0))
    return std::numeric_limits<double>::infinity();
  return e.dot(ldlt.solve(e));
}

UncertainPose composeChain(const std::vector<UncertainPose>& steps) {
  UncertainPose chain;
  for (const UncertainPose& step : steps) {
    chain.covariance = geometry::composeCovariance(chain.pose, chain.covariance, step.pose, step.covariance);
    chain.pose = chain.pose * step.pose;
  }
  return chain;
}

namespace {

// Bron–Kerbosch with pivoting over candidate sets kept as index lists (a few tens).
void extendClique(const std::vector<std::vector<char>>& adjacent, std::vector<int>& clique, std::vector<int> candidates,
                  std::vector<int> excluded, std::vector<int>& best) {
  if (candidates.empty()) {
    if (excluded.empty() && clique.size() > best.size()) best = clique;
    return;
  }
  if (clique.size() + candidates.size() <= best.size()) return;  // cannot beat the best
  // Pivot: the vertex of candidates ∪ excluded with the most neighbours among candidates.
  int pivot = candidates.front();
  std::size_t pivot_degree = 0;
  for (const auto* set : {&candidates, &excluded})
    for (int u : *set) {
      std::size_t degree = 0;
      for (int v : candidates) degree += adjacent[u][v] ? 1 : 0;
      if (degree > pivot_degree) {
        pivot_degree = degree;
        pivot = u;
      }
    }
  std::vector<int> branch;
  for (int v : candidates)
    if (v == pivot || !adjacent[pivot][v]) branch.push_back(v);
  for (int v : branch) {
    std::vector<int> next_candidates, next_excluded;
    for (int u : candidates)
      if (u != v && adjacent[v][u]) next_candidates.push_back(u);
    for (int u : excluded)
      if (adjacent[v][u]) next_excluded.push_back(u);
    clique.push_back(v);
    extendClique(adjacent, clique, std::move(next_candidates), std::move(next_excluded), best);
    clique.pop_back();
    candidates.erase(std::find(candidates.begin(), candidates.end(), v));
    excluded.push_back(v);
  }
}

}  // namespace

std::vector<int> largestCliqueContaining(const std::vector<std::vector<char>>& adjacent, int must) {
  const int n = static_cast<int>(adjacent.size());
  if (must < 0 || must >= n) throw std::out_of_range("largestCliqueContaining: no such vertex");
  for (const auto& row : adjacent)
    if (static_cast<int>(row.size()) != n) throw std::invalid_argument("largestCliqueContaining: not square");
  std::vector<int> clique{must}, candidates, best;
  for (int v = 0; v < n; ++v)
    if (v != must && adjacent[must][v]) candidates.push_back(v);
  extendClique(adjacent, clique, std::move(candidates), {}, best);
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace storey::mapping
