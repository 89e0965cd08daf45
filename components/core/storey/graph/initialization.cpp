#include "storey/graph/initialization.h"

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <chrono>
#include <cmath>
#include <deque>

#include "storey/common/log.h"
#include "storey/graph/linear_solver.h"

namespace storey::graph {

using common::str;
using geometry::Pose2;

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

// Solves the SPD system given by the upper-triangle triplets (duplicates summed) with the
// CHOLMOD backend. `blocks` (optional) is the same pattern over blocks of `block_size`
// variables, so the ordering runs on the smaller block graph (blocks->block_ordering, when
// set, is used as that ordering); without it the system is its own block pattern. The
// pattern of `m` and the block ordering used are returned in *pattern for reuse as a block
// pattern.
Eigen::VectorXd solveUpper(int n, const Triplets& upper, const Eigen::VectorXd& rhs,
                           const char* what, const SparseUpper* blocks, int block_size,
                           SparseUpper* pattern) {
  Eigen::SparseMatrix<double, Eigen::ColMajor, int> a(n, n);
  a.setFromTriplets(upper.begin(), upper.end());
  a.makeCompressed();
  SparseUpper m;
  m.n = n;
  m.col_ptr.assign(a.outerIndexPtr(), a.outerIndexPtr() + n + 1);
  m.row_idx.assign(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros());
  m.values.assign(a.valuePtr(), a.valuePtr() + a.nonZeros());
  if (blocks) {
    m.block_size = block_size;
    m.block_col_ptr = blocks->col_ptr;
    m.block_row_idx = blocks->row_idx;
    m.block_ordering = blocks->block_ordering;
  } else {
    m.block_size = 1;
    m.block_col_ptr = m.col_ptr;
    m.block_row_idx = m.row_idx;
  }
  std::unique_ptr<LinearSolver> solver = makeLinearSolver("cholmod");
  solver->analyze(m);
  if (!solver->factorize(m)) {
    throw GraphError(
        str("orientation-first initialisation: the ", what, " system is not positive definite"));
  }
  Eigen::MatrixXd x;
  solver->solve(rhs, &x);
  if (pattern) {
    pattern->n = n;
    pattern->col_ptr = std::move(m.col_ptr);
    pattern->row_idx = std::move(m.row_idx);
    pattern->block_ordering = solver->blockOrdering();  // AMD once for both systems
  }
  return x.col(0);
}

}  // namespace

OrientationFirstInfo initializeOrientationFirst(PoseGraph& graph) {
  const auto start = std::chrono::steady_clock::now();
  OrientationFirstInfo info;
  const std::size_t n = graph.numNodes();
  if (n == 0) return info;
  const auto& nodes = graph.nodes();
  const auto& edges = graph.edges();

  // Anchors: fixed nodes, else the first node of each component.
  int count = 0;
  const std::vector<int> component = graph.connectedComponents(&count);
  std::vector<char> fixed(n, 0), anchored(count, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (nodes[i].fixed) fixed[i] = anchored[component[i]] = 1;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!anchored[component[i]]) fixed[i] = anchored[component[i]] = 1;
  }

  // Unwrapped orientations along a breadth-first tree from the anchors (shortest paths
  // accumulate the least rotation drift, which decides each edge's 2π multiple below).
  std::vector<std::vector<std::size_t>> adjacent(n);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    if (!edges[e].enabled) continue;
    adjacent[graph.edgeFromIndex(e)].push_back(e);
    adjacent[graph.edgeToIndex(e)].push_back(e);
  }
  std::vector<double> tree(n, 0.0);
  std::vector<char> seen(n, 0);
  std::deque<std::size_t> queue;
  for (std::size_t i = 0; i < n; ++i) {
    if (fixed[i]) {
      tree[i] = nodes[i].pose.theta();
      seen[i] = 1;
      queue.push_back(i);
    }
  }
  while (!queue.empty()) {
    const std::size_t i = queue.front();
    queue.pop_front();
    for (std::size_t e : adjacent[i]) {
      const std::size_t from = graph.edgeFromIndex(e), to = graph.edgeToIndex(e);
      const double delta = edges[e].measurement.theta();
      const std::size_t other = from == i ? to : from;
      if (seen[other]) continue;
      seen[other] = 1;
      tree[other] = from == i ? tree[i] + delta : tree[i] - delta;
      queue.push_back(other);
    }
  }

  std::vector<int> var(n, -1);
  int vars = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!fixed[i]) var[i] = vars++;
  }
  info.nodes = static_cast<std::size_t>(vars);
  info.anchored = fixed;
  if (vars == 0) return info;

  // Orientations: θj − θi = δ + 2πk per edge, weighted by 1 / Σθθ.
  Triplets upper;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(vars);
  std::vector<double> theta = tree;
  std::vector<Eigen::Matrix3d> covariance(edges.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    if (!edges[e].enabled) continue;
    const std::size_t i = graph.edgeFromIndex(e), j = graph.edgeToIndex(e);
    if (fixed[i] && fixed[j]) continue;
    covariance[e] = edges[e].information.inverse();
    const double w = 1.0 / covariance[e](2, 2);
    const double k = std::round((tree[j] - tree[i] - edges[e].measurement.theta()) / (2 * M_PI));
    if (k != 0.0) ++info.wrapped_edges;
    const double target = edges[e].measurement.theta() + 2 * M_PI * k;
    // w (θj − θi − target)²: gradient terms into the normal equations.
    const int vi = var[i], vj = var[j];
    if (vi >= 0) {
      upper.emplace_back(vi, vi, w);
      rhs[vi] -= w * target;
    }
    if (vj >= 0) {
      upper.emplace_back(vj, vj, w);
      rhs[vj] += w * target;
    }
    if (vi >= 0 && vj >= 0) {
      upper.emplace_back(std::min(vi, vj), std::max(vi, vj), -w);
    } else if (vi >= 0) {
      rhs[vi] += w * tree[j];
    } else {
      rhs[vj] += w * tree[i];
    }
  }
  // The orientation system has the pose graph's pattern: the position system's blocks.
  SparseUpper node_pattern;
  const Eigen::VectorXd th = solveUpper(vars, upper, rhs, "orientation", nullptr, 1, &node_pattern);
  info.ordering = node_pattern.block_ordering;
  for (std::size_t i = 0; i < n; ++i) {
    if (var[i] >= 0) theta[i] = th[var[i]];
  }

  // Positions: tj − ti = R(θi) t_z per edge, weighted by R Σxy⁻¹ Rᵀ.
  upper.clear();
  rhs = Eigen::VectorXd::Zero(2 * vars);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    if (!edges[e].enabled) continue;
    const std::size_t i = graph.edgeFromIndex(e), j = graph.edgeToIndex(e);
    if (fixed[i] && fixed[j]) continue;
    const Eigen::Rotation2Dd r(theta[i]);
    const Eigen::Matrix2d rot = r.toRotationMatrix();
    const Eigen::Matrix2d w = rot * covariance[e].topLeftCorner<2, 2>().inverse() * rot.transpose();
    const Eigen::Vector2d d = rot * edges[e].measurement.translation();
    const int vi = var[i], vj = var[j];
    const Eigen::Vector2d wd = w * d;
    auto addBlock = [&](int a, int b, const Eigen::Matrix2d& block) {
      // Upper triangle of the 2×2-block pattern only.
      for (int p = 0; p < 2; ++p) {
        for (int q = 0; q < 2; ++q) {
          const int row = 2 * a + p, col = 2 * b + q;
          if (row <= col) upper.emplace_back(row, col, block(p, q));
        }
      }
    };
    if (vi >= 0) {
      addBlock(vi, vi, w);
      rhs.segment<2>(2 * vi) -= wd;
    }
    if (vj >= 0) {
      addBlock(vj, vj, w);
      rhs.segment<2>(2 * vj) += wd;
    }
    if (vi >= 0 && vj >= 0) {
      if (vi < vj) {
        addBlock(vi, vj, -w);
      } else {
        addBlock(vj, vi, -w.transpose());
      }
    } else if (vi >= 0) {
      rhs.segment<2>(2 * vi) += w * nodes[j].pose.translation();
    } else {
      rhs.segment<2>(2 * vj) += w * nodes[i].pose.translation();
    }
  }
  const Eigen::VectorXd t = solveUpper(2 * vars, upper, rhs, "position", &node_pattern, 2, nullptr);
  for (std::size_t i = 0; i < n; ++i) {
    const int v = var[i];
    if (v < 0) continue;
    graph.setPoseAt(i, Pose2(t[2 * v], t[2 * v + 1], std::remainder(theta[i], 2 * M_PI)));
  }
  info.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return info;
}

}  // namespace storey::graph
