// Sparse symmetric positive-definite solvers for the optimiser's normal equations. The
// matrix is given as its upper triangle in compressed sparse columns; the pattern is
// analysed once (ordering, symbolic factorisation) and reused for every numeric
// factorisation until analyze() is called again. Backends: "cholmod" (SuiteSparse CHOLMOD,
// simplicial LDLᵀ, AMD), "cholmod_supernodal" (CHOLMOD supernodal LLᵀ on BLAS, AMD),
// "cholmod_nd" (supernodal, METIS nested dissection) — CHOLMOD stays private to its .cpp —
// and "eigen" (Eigen's SimplicialLDLT, a dependency-free reference).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace storey::graph {

// Upper triangle (row <= column) of a symmetric n×n matrix, compressed by column with rows
// sorted. `block_*` optionally describe the same pattern over blocks of `block_size`
// variables (one block per pose), which lets a backend order by blocks.
struct SparseUpper {
  int n = 0;
  std::vector<int> col_ptr;  // n + 1 entries
  std::vector<int> row_idx;
  std::vector<double> values;
  int block_size = 1;
  std::vector<int> block_col_ptr;  // empty when no block pattern is given
  std::vector<int> block_row_idx;
  // Optional fill-reducing order of the blocks (new → old) to use instead of computing one,
  // e.g. LinearSolver::blockOrdering() of another system on the same block pattern.
  std::vector<int> block_ordering;
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  virtual const char* name() const = 0;
  // Ordering and symbolic factorisation of the pattern (values are ignored).
  virtual void analyze(const SparseUpper& matrix) = 0;
  // Numeric factorisation with the analysed pattern; false when not positive definite.
  virtual bool factorize(const SparseUpper& matrix) = 0;
  // Solves A X = B with the last factorisation (B is n × k, column-major).
  virtual void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) = 0;
  // The block ordering used by the last analyze() (empty when the backend orders itself).
  virtual std::vector<int> blockOrdering() const { return {}; }
  // Flop estimates from the last analyze(): one numeric factorisation and one solve with
  // one right-hand side (0 when the backend does not know).
  virtual double factorizationFlops() const { return 0.0; }
  virtual double solveFlops() const { return 0.0; }
};

// "cholmod", "cholmod_supernodal", "cholmod_nd" or "eigen"; throws std::invalid_argument
// otherwise. ("auto" is resolved by the optimiser from the graph's size.)
std::unique_ptr<LinearSolver> makeLinearSolver(const std::string& name);
// Nested dissection (METIS on the block pattern) implies supernodal.
std::unique_ptr<LinearSolver> makeCholmodSolver(bool supernodal = false,
                                                bool nested_dissection = false);
std::unique_ptr<LinearSolver> makeEigenSolver();

}  // namespace storey::graph
