#include "storey/graph/linear_solver.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <set>
#include <utility>

namespace storey::graph {
namespace {

// A random symmetric positive-definite matrix on a random 3×3-block pattern (a chain plus
// random links), stored as SparseUpper with its block pattern, and its dense copy.
SparseUpper randomBlockMatrix(int blocks, int links, unsigned seed, Eigen::MatrixXd* dense) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, blocks - 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::set<std::pair<int, int>> pairs;  // (lower, higher) block indices
  for (int k = 0; k + 1 < blocks; ++k) pairs.insert({k, k + 1});
  while (static_cast<int>(pairs.size()) < blocks - 1 + links) {
    const int a = pick(rng), b = pick(rng);
    if (a != b) pairs.insert({std::min(a, b), std::max(a, b)});
  }
  const int n = 3 * blocks;
  // H = Σ Jᵀ J over the pairs plus a small diagonal: positive definite with that pattern.
  *dense = 0.1 * Eigen::MatrixXd::Identity(n, n);
  for (const auto& [a, b] : pairs) {
    Eigen::Matrix<double, 3, 6> j;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 6; ++c) j(r, c) = normal(rng);
    }
    const Eigen::Matrix<double, 6, 6> h = j.transpose() * j;
    const int index[2] = {a, b};
    for (int p = 0; p < 2; ++p) {
      for (int q = 0; q < 2; ++q) {
        dense->block<3, 3>(3 * index[p], 3 * index[q]) += h.block<3, 3>(3 * p, 3 * q);
      }
    }
  }
  std::vector<std::set<int>> rows(blocks);  // block rows ≤ column, per block column
  for (int k = 0; k < blocks; ++k) rows[k].insert(k);
  for (const auto& [a, b] : pairs) rows[b].insert(a);
  SparseUpper m;
  m.n = n;
  m.block_size = 3;
  m.col_ptr.assign(n + 1, 0);
  m.block_col_ptr.assign(blocks + 1, 0);
  for (int k = 0; k < blocks; ++k) {
    m.block_col_ptr[k + 1] = m.block_col_ptr[k] + static_cast<int>(rows[k].size());
    for (int r : rows[k]) m.block_row_idx.push_back(r);
    for (int a = 0; a < 3; ++a) {
      const int col = 3 * k + a;
      for (int r : rows[k]) {
        for (int p = 0; p < 3; ++p) {
          const int row = 3 * r + p;
          if (row > col) continue;
          m.row_idx.push_back(row);
          m.values.push_back((*dense)(row, col));
        }
      }
      m.col_ptr[col + 1] = static_cast<int>(m.row_idx.size());
    }
  }
  return m;
}

TEST(LinearSolver, EveryBackendSolvesSeveralRightHandSides) {
  Eigen::MatrixXd dense;
  SparseUpper m = randomBlockMatrix(60, 80, 5, &dense);
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd b(m.n, 4);
  for (Eigen::Index i = 0; i < b.size(); ++i) b.data()[i] = normal(rng);
  const Eigen::MatrixXd expected = dense.llt().solve(b);
  for (const char* name : {"cholmod", "cholmod_supernodal", "cholmod_nd", "eigen"}) {
    SCOPED_TRACE(name);
    auto solver = makeLinearSolver(name);
    solver->analyze(m);
    ASSERT_TRUE(solver->factorize(m));
    Eigen::MatrixXd x;
    solver->solve(b, &x);
    EXPECT_LT((x - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff());
    // New values on the same pattern: refactorised without a new analysis.
    SparseUpper scaled = m;
    for (double& v : scaled.values) v *= 2.0;
    ASSERT_TRUE(solver->factorize(scaled));
    solver->solve(b, &x);
    EXPECT_LT((2.0 * x - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff());
  }
}

TEST(LinearSolver, IndefiniteMatrixIsReported) {
  Eigen::MatrixXd dense;
  SparseUpper m = randomBlockMatrix(20, 10, 6, &dense);
  // Make one diagonal entry strongly negative.
  for (int q = m.col_ptr[7]; q < m.col_ptr[8]; ++q) {
    if (m.row_idx[q] == 7) m.values[q] = -100.0;
  }
  for (const char* name : {"cholmod", "cholmod_supernodal", "eigen"}) {
    auto solver = makeLinearSolver(name);
    solver->analyze(m);
    EXPECT_FALSE(solver->factorize(m)) << name;
  }
}

}  // namespace
}  // namespace storey::graph
