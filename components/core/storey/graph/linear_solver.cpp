#include "storey/graph/linear_solver.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <stdexcept>

namespace storey::graph {

namespace {

class EigenSolver : public LinearSolver {
 public:
  const char* name() const override { return "eigen"; }

  void analyze(const SparseUpper& matrix) override {
    ldlt_.analyzePattern(view(matrix));
    analysed_ = true;
  }

  bool factorize(const SparseUpper& matrix) override {
    if (!analysed_) analyze(matrix);
    ldlt_.factorize(view(matrix));
    if (ldlt_.info() != Eigen::Success) return false;
    // LDLᵀ accepts indefinite matrices; a normal-equation matrix must have D > 0.
    return (ldlt_.vectorD().array() > 0.0).all();
  }

  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) override { *x = ldlt_.solve(b); }

 private:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  static Eigen::Map<const Matrix> view(const SparseUpper& m) {
    return Eigen::Map<const Matrix>(m.n, m.n, static_cast<int>(m.values.size()), m.col_ptr.data(),
                                    m.row_idx.data(), m.values.data());
  }

  Eigen::SimplicialLDLT<Matrix, Eigen::Upper, Eigen::AMDOrdering<int>> ldlt_;
  bool analysed_ = false;
};

}  // namespace

std::unique_ptr<LinearSolver> makeEigenSolver() { return std::make_unique<EigenSolver>(); }

std::unique_ptr<LinearSolver> makeLinearSolver(const std::string& name) {
  if (name == "cholmod") return makeCholmodSolver(false);
  if (name == "cholmod_supernodal") return makeCholmodSolver(true);
  if (name == "cholmod_nd") return makeCholmodSolver(true, true);
  if (name == "eigen") return makeEigenSolver();
  throw std::invalid_argument("unknown linear solver '" + name +
                              "' (cholmod, cholmod_supernodal, cholmod_nd, eigen)");
}

}  // namespace storey::graph
