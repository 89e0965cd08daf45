// CHOLMOD backend: simplicial LDLᵀ with AMD ("cholmod"), supernodal LLᵀ with AMD
// ("cholmod_supernodal") or supernodal LLᵀ with METIS nested dissection ("cholmod_nd").
// Simplicial AMD measured fastest here on every shared graph (docs/optimizer.md); METIS
// has 13 % fewer flops on city10000 but its ordering time and the supernodal kernels ate
// that. Orderings are computed on the block (pose) pattern, 9× smaller than the scalar
// one, and expanded to the scalar variables; the symbolic factor is kept until the next
// analyze().
#include <cholmod.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "storey/graph/linear_solver.h"

namespace storey::graph {

namespace {

class CholmodSolver : public LinearSolver {
 public:
  CholmodSolver(bool supernodal, bool nested_dissection)
      : supernodal_(supernodal), nested_dissection_(nested_dissection) {
    cholmod_start(&common_);
    common_.supernodal = supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
    common_.print = 0;
    common_.error_handler = nullptr;
    started_ = true;
  }

  ~CholmodSolver() override {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    if (started_) cholmod_finish(&common_);
  }

  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  const char* name() const override {
    if (nested_dissection_) return "cholmod_nd";
    return supernodal_ ? "cholmod_supernodal" : "cholmod";
  }

  void analyze(const SparseUpper& matrix) override {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    permuted_ = false;
    cholmod_sparse a = view(matrix);
    std::vector<int> perm;
    block_perm_.clear();
    if (!matrix.block_col_ptr.empty() && matrix.block_size >= 1) {
      perm = blockOrdering(matrix);
    }
    common_.nmethods = 1;
    if (!perm.empty() && !supernodal_) {
      // cholmod_factorize permutes an upper-triangle matrix with two transposes (each
      // allocated anew) before every simplicial factorisation. We permute it ourselves once
      // per structure into S = A(p,p) and keep a gather map: every factorisation then copies
      // the values and factorises S in its natural order (same matrix, no transposes).
      perm_ = std::move(perm);
      permute(matrix);
      cholmod_sparse sv = view(permuted_matrix_);
      common_.method[0].ordering = CHOLMOD_NATURAL;
      common_.postorder = 0;  // AMD's block order is already postordered
      factor_ = cholmod_analyze(&sv, &common_);
      permuted_ = true;
    } else if (!perm.empty()) {
      common_.method[0].ordering = CHOLMOD_GIVEN;
      common_.postorder = 1;
      factor_ = cholmod_analyze_p(&a, perm.data(), nullptr, 0, &common_);
    } else {
      common_.method[0].ordering = CHOLMOD_AMD;
      common_.postorder = 1;
      factor_ = cholmod_analyze(&a, &common_);
    }
    if (!factor_) throw std::runtime_error("CHOLMOD symbolic analysis failed");
    n_ = matrix.n;
    // From this analysis: flops of the factorisation, nonzeros of L (a solve with L, D and
    // Lᵀ reads each twice).
    factorization_flops_ = common_.fl;
    solve_flops_ = 4.0 * common_.lnz;
  }

  double factorizationFlops() const override { return factorization_flops_; }
  double solveFlops() const override { return solve_flops_; }

  bool factorize(const SparseUpper& matrix) override {
    if (!factor_ || n_ != matrix.n) analyze(matrix);
    cholmod_sparse a = view(matrix);
    if (permuted_) {
      double* x = permuted_matrix_.values.data();
      const double* values = matrix.values.data();
      for (std::size_t k = 0; k < gather_.size(); ++k) x[k] = values[gather_[k]];
      a = view(permuted_matrix_);
    }
    common_.status = CHOLMOD_OK;
    cholmod_factorize(&a, factor_, &common_);
    if (common_.status != CHOLMOD_OK || factor_->minor != factor_->n) return false;
    if (!factor_->is_super && !factor_->is_ll) {
      // Simplicial LDLᵀ accepts an indefinite matrix; normal equations need D > 0. D sits
      // first in each column of L (its unit diagonal is implicit).
      const int* lp = static_cast<const int*>(factor_->p);
      const double* lx = static_cast<const double*>(factor_->x);
      for (std::size_t j = 0; j < factor_->n; ++j) {
        if (!(lx[lp[j]] > 0.0)) return false;
      }
    }
    return true;
  }

  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x) override {
    if (!factor_) throw std::logic_error("CHOLMOD solve before factorisation");
    const Eigen::MatrixXd* source = &b;
    if (permuted_) {
      // S = A(p,p): solve S y = b(p), then x(p) = y.
      rhs_.resize(b.rows(), b.cols());
      for (Eigen::Index k = 0; k < b.rows(); ++k) rhs_.row(k) = b.row(perm_[k]);
      source = &rhs_;
    }
    cholmod_dense rhs;
    std::memset(&rhs, 0, sizeof(rhs));
    rhs.nrow = source->rows();
    rhs.ncol = source->cols();
    rhs.nzmax = source->size();
    rhs.d = source->rows();
    rhs.x = const_cast<double*>(source->data());
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* result = cholmod_solve(CHOLMOD_A, factor_, &rhs, &common_);
    if (!result) throw std::runtime_error("CHOLMOD solve failed");
    x->resize(b.rows(), b.cols());
    const Eigen::Map<const Eigen::MatrixXd> y(static_cast<const double*>(result->x), b.rows(),
                                              b.cols());
    if (permuted_) {
      for (Eigen::Index k = 0; k < b.rows(); ++k) x->row(perm_[k]) = y.row(k);
    } else {
      *x = y;
    }
    cholmod_free_dense(&result, &common_);
  }

 private:
  // A non-owning CHOLMOD view of the matrix (CHOLMOD reads it, never frees it).
  static cholmod_sparse view(const SparseUpper& m) {
    cholmod_sparse a;
    std::memset(&a, 0, sizeof(a));
    a.nrow = m.n;
    a.ncol = m.n;
    a.nzmax = m.values.size();
    a.p = const_cast<int*>(m.col_ptr.data());
    a.i = const_cast<int*>(m.row_idx.data());
    a.x = const_cast<double*>(m.values.data());
    a.stype = 1;  // upper triangle holds the matrix
    a.itype = CHOLMOD_INT;
    a.xtype = m.values.empty() ? CHOLMOD_PATTERN : CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    return a;
  }

  // permuted_matrix_ = upper triangle of A(p,p) with p = perm_, and gather_[k] the position
  // in A's values of its k-th value. Entries are bucketed by row, then appended to their
  // columns row by row, so rows come out sorted without a sort.
  void permute(const SparseUpper& m) {
    const int n = m.n;
    const std::size_t nnz = m.row_idx.size();
    std::vector<int> inverse(n);
    for (int k = 0; k < n; ++k) inverse[perm_[k]] = k;
    std::vector<int> row_ptr(n + 1, 0), col_count(n + 1, 0);
    for (int j = 0; j < n; ++j) {
      for (int q = m.col_ptr[j]; q < m.col_ptr[j + 1]; ++q) {
        const int a = inverse[m.row_idx[q]], b = inverse[j];
        ++row_ptr[std::min(a, b) + 1];
        ++col_count[std::max(a, b) + 1];
      }
    }
    for (int k = 0; k < n; ++k) row_ptr[k + 1] += row_ptr[k];
    std::vector<int> by_row(nnz), next(row_ptr.begin(), row_ptr.end() - 1);
    for (int j = 0; j < n; ++j) {
      for (int q = m.col_ptr[j]; q < m.col_ptr[j + 1]; ++q) {
        by_row[next[std::min(inverse[m.row_idx[q]], inverse[j])]++] = q;
      }
    }
    SparseUpper& s = permuted_matrix_;
    s = SparseUpper();
    s.n = n;
    s.col_ptr.assign(n + 1, 0);
    for (int j = 0; j < n; ++j) s.col_ptr[j + 1] = s.col_ptr[j] + col_count[j + 1];
    s.row_idx.resize(nnz);
    s.values.assign(nnz, 0.0);
    gather_.resize(nnz);
    // Column of each original entry: the larger permuted index of its row and column.
    std::vector<int> column_of(nnz);
    for (int j = 0; j < n; ++j) {
      for (int q = m.col_ptr[j]; q < m.col_ptr[j + 1]; ++q) {
        column_of[q] = std::max(inverse[m.row_idx[q]], inverse[j]);
      }
    }
    next.assign(s.col_ptr.begin(), s.col_ptr.end() - 1);
    for (int r = 0; r < n; ++r) {
      for (int k = row_ptr[r]; k < row_ptr[r + 1]; ++k) {
        const int q = by_row[k];
        const int pos = next[column_of[q]]++;
        s.row_idx[pos] = r;
        gather_[pos] = q;
      }
    }
  }

  std::vector<int> blockOrdering() const override { return block_perm_; }

  std::vector<int> blockOrdering(const SparseUpper& m) {
    const int blocks = static_cast<int>(m.block_col_ptr.size()) - 1;
    if (blocks <= 0 || blocks * m.block_size != m.n) return {};
    std::vector<int> block_perm;
    if (static_cast<int>(m.block_ordering.size()) == blocks) {
      block_perm = m.block_ordering;  // given by the caller
    } else {
      SparseUpper pattern;
      pattern.n = blocks;
      pattern.col_ptr = m.block_col_ptr;
      pattern.row_idx = m.block_row_idx;
      cholmod_sparse b = view(pattern);
      block_perm.resize(blocks);
      const bool ok = nested_dissection_
                          ? cholmod_metis(&b, nullptr, 0, 1, block_perm.data(), &common_)
                          : cholmod_amd(&b, nullptr, 0, block_perm.data(), &common_);
      if (!ok) return {};
    }
    block_perm_ = block_perm;
    std::vector<int> perm(m.n);
    for (int k = 0; k < blocks; ++k) {
      for (int d = 0; d < m.block_size; ++d) {
        perm[k * m.block_size + d] = block_perm[k] * m.block_size + d;
      }
    }
    return perm;
  }

  cholmod_common common_;
  cholmod_factor* factor_ = nullptr;
  bool supernodal_;
  bool nested_dissection_;
  bool started_ = false;
  int n_ = -1;
  // Simplicial: the matrix is factorised as S = A(p,p) in natural order (see analyze()).
  bool permuted_ = false;
  double factorization_flops_ = 0.0;
  double solve_flops_ = 0.0;
  std::vector<int> perm_;
  std::vector<int> block_perm_;
  std::vector<int> gather_;
  SparseUpper permuted_matrix_;
  Eigen::MatrixXd rhs_;
};

}  // namespace

std::unique_ptr<LinearSolver> makeCholmodSolver(bool supernodal, bool nested_dissection) {
  return std::make_unique<CholmodSolver>(supernodal || nested_dissection, nested_dissection);
}

}  // namespace storey::graph
