#include "storey/graph/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>

#include "storey/common/log.h"
#include "storey/graph/optimizer_internal.h"

namespace storey::graph {

using common::str;
using geometry::Pose2;

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

Optimizer::Optimizer(OptimizerOptions options) : options_(std::move(options)) {}
Optimizer::~Optimizer() = default;
Optimizer::Optimizer(Optimizer&&) noexcept = default;
Optimizer& Optimizer::operator=(Optimizer&&) noexcept = default;

void Optimizer::setOptions(const OptimizerOptions& options) {
  if (options.linear_solver != options_.linear_solver) {
    solver_.reset();
    structure_.reset();
  }
  options_ = options;
}

namespace {

// The gauge: which nodes are held constant. Throws when a component has none and the
// mode does not allow fixing one.
void chooseGauge(const PoseGraph& graph, GaugeMode mode, std::vector<char>* fixed,
                 std::vector<NodeId>* auto_fixed, int* components) {
  const std::size_t n = graph.numNodes();
  fixed->assign(n, 0);
  auto_fixed->clear();
  bool any_fixed = false;
  for (std::size_t i = 0; i < n; ++i) {
    (*fixed)[i] = graph.nodes()[i].fixed ? 1 : 0;
    any_fixed = any_fixed || graph.nodes()[i].fixed;
  }
  int count = 0;
  const std::vector<int> component = graph.connectedComponents(&count);
  *components = count;
  if (mode == GaugeMode::kFirstNode && !any_fixed && n > 0) {
    (*fixed)[0] = 1;
    auto_fixed->push_back(graph.nodes()[0].id);
  }
  std::vector<char> anchored(count, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if ((*fixed)[i]) anchored[component[i]] = 1;
  }
  int missing = 0;
  NodeId example = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const int c = component[i];
    if (anchored[c]) continue;
    if (mode == GaugeMode::kPerComponent) {
      (*fixed)[i] = 1;
      auto_fixed->push_back(graph.nodes()[i].id);
    } else {
      if (missing == 0) example = graph.nodes()[i].id;
      ++missing;
    }
    anchored[c] = 1;
  }
  if (missing > 0) {
    throw GraphError(str("the graph has ", count, " connected components and ", missing,
                         " of them have no fixed node (e.g. the one containing node ", example,
                         "): fix a node in each, or use gauge per_component"));
  }
}

}  // namespace

OptimizerResult Optimizer::optimize(PoseGraph& graph) {
  const Clock::time_point start = Clock::now();
  OptimizerResult result;
  if (graph.numNodes() == 0) throw GraphError("cannot optimise an empty graph");

  // --- Structure (only when it changed).
  Clock::time_point phase = Clock::now();
  std::vector<char> fixed;
  std::vector<NodeId> auto_fixed;
  int components = 0;
  chooseGauge(graph, options_.gauge, &fixed, &auto_fixed, &components);
  result.components = components;
  result.auto_fixed = auto_fixed;
  std::vector<int> init_ordering;
  if (options_.initialization != Initialization::kNone) {
    result.initial_chi2 = graph.chi2();
    bool robust = false;
    for (const RobustKernel& k : options_.robust)
      robust = robust || k.type != RobustKernelType::kNone;
    std::size_t enabled = 0;
    for (const Edge& edge : graph.edges()) enabled += edge.enabled ? 1 : 0;
    result.initialized =
        options_.initialization == Initialization::kOrientationFirst ||
        (!robust &&
         result.initial_chi2 > options_.auto_initialization_chi2 *
                                   static_cast<double>(std::max<std::size_t>(enabled, 1)));
    // Its anchors are the gauge's fixed nodes (same rule), so fixed poses stay put.
    if (result.initialized) {
      OrientationFirstInfo info = initializeOrientationFirst(graph);
      result.time.initialization = info.seconds;
      // Same anchors as the gauge: the same pose graph, so its AMD order serves H too.
      if (info.anchored == fixed) init_ordering = std::move(info.ordering);
    }
    phase = Clock::now();
  }
  if (!structure_ || structure_->graph_version != graph.structureVersion() ||
      structure_->fixed != fixed) {
    auto s = std::make_unique<Structure>();
    s->graph_version = graph.structureVersion();
    s->fixed = fixed;
    s->auto_fixed = auto_fixed;
    s->components = components;
    const std::size_t n = graph.numNodes();
    s->var_of_node.assign(n, -1);
    for (std::size_t i = 0; i < n; ++i) {
      if (!fixed[i]) {
        s->var_of_node[i] = static_cast<int>(s->node_of_var.size());
        s->node_of_var.push_back(i);
      }
    }
    const int vars = static_cast<int>(s->node_of_var.size());
    std::vector<std::vector<int>> lower(vars);  // block rows above the diagonal per column
    for (std::size_t e = 0; e < graph.numEdges(); ++e) {
      const int a = s->var_of_node[graph.edgeFromIndex(e)];
      const int b = s->var_of_node[graph.edgeToIndex(e)];
      if (a >= 0 && b >= 0) lower[std::max(a, b)].push_back(std::min(a, b));
    }
    for (auto& rows : lower) {
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    }
    SparseUpper& h = s->h;
    h.n = 3 * vars;
    h.block_size = 3;
    h.col_ptr.assign(h.n + 1, 0);
    h.block_col_ptr.assign(vars + 1, 0);
    s->diag.resize(vars);
    for (int k = 0; k < vars; ++k) {
      h.block_col_ptr[k + 1] = h.block_col_ptr[k] + static_cast<int>(lower[k].size()) + 1;
      for (int m : lower[k]) h.block_row_idx.push_back(m);
      h.block_row_idx.push_back(k);
      for (int a = 0; a < 3; ++a) {
        const int col = 3 * k + a;
        for (int m : lower[k]) {
          for (int p = 0; p < 3; ++p) h.row_idx.push_back(3 * m + p);
        }
        s->diag[k][a] = static_cast<int>(h.row_idx.size());
        for (int p = 0; p <= a; ++p) h.row_idx.push_back(3 * k + p);
        h.col_ptr[col + 1] = static_cast<int>(h.row_idx.size());
      }
    }
    h.values.assign(h.row_idx.size(), 0.0);
    s->diag_entry.resize(h.n);
    for (int k = 0; k < vars; ++k) {
      for (int a = 0; a < 3; ++a) s->diag_entry[3 * k + a] = s->diag[k][a] + a;
    }
    s->offdiag.assign(graph.numEdges(), {-1, -1, -1});
    for (std::size_t e = 0; e < graph.numEdges(); ++e) {
      const int a = s->var_of_node[graph.edgeFromIndex(e)];
      const int b = s->var_of_node[graph.edgeToIndex(e)];
      if (a < 0 || b < 0) continue;
      const int k = std::max(a, b), m = std::min(a, b);
      const int pos = static_cast<int>(std::lower_bound(lower[k].begin(), lower[k].end(), m) -
                                       lower[k].begin());
      for (int c = 0; c < 3; ++c) s->offdiag[e][c] = h.col_ptr[3 * k + c] + 3 * pos;
    }
    if (static_cast<int>(init_ordering.size()) == vars) h.block_ordering = init_ordering;
    structure_ = std::move(s);
    result.reanalysed = true;
  }
  Structure& s = *structure_;
  const int n_vars = static_cast<int>(s.node_of_var.size());
  if (!solver_) {
    solver_ = makeLinearSolver(options_.linear_solver);
    s.analysed = false;
  }
  if ((result.reanalysed || !s.analysed) && n_vars > 0) {
    result.reanalysed = true;
    solver_->analyze(s.h);
    s.analysed = true;
  }
  result.time.symbolic = secondsSince(phase);

  std::array<RobustKernel, kEdgeKindCount> kernels = options_.robust;
  const auto& edges = graph.edges();

  // edgeResidual() without its two sin/cos per edge: the measurements' terms are computed
  // once per call, each node's cos/sin once per evaluation (cos(θi + θz) from both).
  struct MeasurementTerms {
    double cz, sz, ex, ey;  // cos θz, sin θz, R(θz)ᵀ tz
  };
  std::vector<MeasurementTerms> terms(edges.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const Pose2& z = edges[e].measurement;
    const double cz = std::cos(z.theta()), sz = std::sin(z.theta());
    terms[e] = {cz, sz, cz * z.x() + sz * z.y(), -sz * z.x() + cz * z.y()};
  }
  std::vector<std::array<double, 2>> node_cs(graph.numNodes());
  auto updateNodeTrig = [&]() {
    for (std::size_t i = 0; i < node_cs.size(); ++i) {
      const double theta = graph.nodes()[i].pose.theta();
      node_cs[i] = {std::cos(theta), std::sin(theta)};
    }
  };
  // Same residual and Jacobians as edgeResidual() (checked against it in the unit tests).
  auto residual = [&](std::size_t e, Eigen::Matrix3d* d_xi, Eigen::Matrix3d* d_xj) {
    const std::size_t i = graph.edgeFromIndex(e), j = graph.edgeToIndex(e);
    const Pose2& xi = graph.nodes()[i].pose;
    const Pose2& xj = graph.nodes()[j].pose;
    const MeasurementTerms& t = terms[e];
    const double c = node_cs[i][0] * t.cz - node_cs[i][1] * t.sz;
    const double sn = node_cs[i][1] * t.cz + node_cs[i][0] * t.sz;
    const double dx = xj.x() - xi.x(), dy = xj.y() - xi.y();
    const Eigen::Vector3d r(
        c * dx + sn * dy - t.ex, -sn * dx + c * dy - t.ey,
        geometry::normalizeAngle(xj.theta() - xi.theta() - edges[e].measurement.theta()));
    if (d_xi) {
      *d_xi << -c, -sn, -sn * dx + c * dy,  //
          sn, -c, -c * dx - sn * dy,        //
          0, 0, -1;
      *d_xj << c, sn, 0,  //
          -sn, c, 0,      //
          0, 0, 1;
    }
    return r;
  };

  // Σ ρ(s) and Σ s at the current poses.
  auto evaluate = [&](double* chi2) {
    updateNodeTrig();
    double cost = 0.0, sum = 0.0;
    for (std::size_t e = 0; e < edges.size(); ++e) {
      const Edge& edge = edges[e];
      if (!edge.enabled) continue;
      const Eigen::Vector3d r = residual(e, nullptr, nullptr);
      const double sq = r.dot(edge.information * r);
      double rho, w;
      robustKernel(kernels[static_cast<int>(edge.kind)], sq, &rho, &w);
      sum += sq;
      cost += rho;
    }
    if (chi2) *chi2 = sum;
    return cost;
  };

  Eigen::VectorXd b(3 * n_vars);
  // Fills H (upper triangle, in s.h.values) and b at the current poses; returns Σ ρ.
  auto assemble = [&](double* chi2) {
    updateNodeTrig();
    std::fill(s.h.values.begin(), s.h.values.end(), 0.0);
    b.setZero();
    double cost = 0.0, sum = 0.0;
    double* values = s.h.values.data();
    Eigen::Matrix3d ji, jj;
    for (std::size_t e = 0; e < edges.size(); ++e) {
      const Edge& edge = edges[e];
      if (!edge.enabled) continue;
      const int vi = s.var_of_node[graph.edgeFromIndex(e)];
      const int vj = s.var_of_node[graph.edgeToIndex(e)];
      const Eigen::Vector3d r = residual(e, &ji, &jj);
      const Eigen::Vector3d omega_r = edge.information * r;
      const double sq = r.dot(omega_r);
      double rho, w;
      robustKernel(kernels[static_cast<int>(edge.kind)], sq, &rho, &w);
      sum += sq;
      cost += rho;
      const Eigen::Matrix3d omega = w * edge.information;
      Eigen::Matrix3d jti, jtj;
      if (vi >= 0) {
        jti.noalias() = ji.transpose() * omega;
        const Eigen::Matrix3d hii = jti * ji;
        for (int a = 0; a < 3; ++a) {
          for (int p = 0; p <= a; ++p) values[s.diag[vi][a] + p] += hii(p, a);
        }
        b.segment<3>(3 * vi) += jti * r;
      }
      if (vj >= 0) {
        jtj.noalias() = jj.transpose() * omega;
        const Eigen::Matrix3d hjj = jtj * jj;
        for (int a = 0; a < 3; ++a) {
          for (int p = 0; p <= a; ++p) values[s.diag[vj][a] + p] += hjj(p, a);
        }
        b.segment<3>(3 * vj) += jtj * r;
      }
      if (vi >= 0 && vj >= 0) {
        // Stored block is H(min, max): rows of the lower-numbered variable.
        const Eigen::Matrix3d block =
            vi < vj ? Eigen::Matrix3d(jti * jj) : Eigen::Matrix3d(jtj * ji);
        for (int a = 0; a < 3; ++a) {
          double* column = values + s.offdiag[e][a];
          for (int p = 0; p < 3; ++p) column[p] += block(p, a);
        }
      }
    }
    if (chi2) *chi2 = sum;
    return cost;
  };

  auto statePoses = [&]() {
    std::vector<Pose2> poses(n_vars);
    for (int k = 0; k < n_vars; ++k) poses[k] = graph.nodes()[s.node_of_var[k]].pose;
    return poses;
  };
  auto stateNorm = [&]() {
    double sq = 0.0;
    for (int k = 0; k < n_vars; ++k)
      sq += graph.nodes()[s.node_of_var[k]].pose.vector().squaredNorm();
    return std::sqrt(sq);
  };
  auto applyStep = [&](const Eigen::VectorXd& dx) {
    for (int k = 0; k < n_vars; ++k) {
      const Pose2& p = graph.nodes()[s.node_of_var[k]].pose;
      graph.setPoseAt(s.node_of_var[k],
                      Pose2(p.x() + dx[3 * k], p.y() + dx[3 * k + 1], p.theta() + dx[3 * k + 2]));
    }
  };

  phase = Clock::now();
  double chi2 = 0.0;
  double cost = n_vars > 0 ? assemble(&chi2) : evaluate(&chi2);
  result.time.assembly += secondsSince(phase);
  if (!result.initialized) result.initial_chi2 = chi2;
  result.initialized_chi2 = chi2;
  result.initial_cost = cost;

  const bool lm = options_.algorithm == Algorithm::kLevenbergMarquardt;
  double lambda = lm ? options_.initial_lambda : 0.0;
  double nu = 2.0;
  Eigen::MatrixXd dx_mat;
  Eigen::MatrixXd rhs;
  if (n_vars == 0) {
    result.converged = true;
    result.termination = "no free nodes";
  }
  // Chord steps: the factor of (H + λD) from the last full step is reused at the new poses
  // while H changes little (near the optimum), as the preconditioner of conjugate gradients
  // on the current system: a few solves instead of one factorisation.
  bool try_chord = false;
  double chord_max_change = options_.chord_max_change;
  double factor_lambda = 0.0;
  std::vector<double> factor_diag;
  // y = (H + λ·diag(max(H_ii, ε))) x from H's upper triangle (the diagonal entry is the last
  // of each column).
  auto multiply = [&](const Eigen::VectorXd& x, double damping, Eigen::VectorXd* y) {
    y->setZero(x.size());
    const SparseUpper& h = s.h;
    for (int j = 0; j < h.n; ++j) {
      const double xj = x[j];
      double yj = 0.0;
      const int last = h.col_ptr[j + 1] - 1;
      for (int q = h.col_ptr[j]; q < last; ++q) {
        const int i = h.row_idx[q];
        (*y)[i] += h.values[q] * xj;
        yj += h.values[q] * x[i];
      }
      const double d = h.values[last];
      (*y)[j] += yj + (d + damping * std::max(d, 1e-6)) * xj;
    }
  };
  // Preconditioned CG on (H + λD)Δ = −b with the last factorisation as the preconditioner;
  // false when the residual does not fall below the tolerance within the iteration cap (or
  // a direction of non-positive curvature appears): H has moved too far from the factor.
  Eigen::MatrixXd z_mat;
  int pcg_iterations = options_.chord_pcg_iterations;
  if (n_vars > 0 && options_.chord_pcg_min_cost > 0.0 && solver_->factorizationFlops() > 0.0) {
    const double iteration = solver_->solveFlops() + 4.0 * static_cast<double>(s.h.values.size());
    if (solver_->factorizationFlops() < options_.chord_pcg_min_cost * iteration) pcg_iterations = 0;
  }
  result.pcg_used = pcg_iterations > 0;
  auto pcg = [&](double damping, Eigen::VectorXd* x) {
    const int n = 3 * n_vars;
    Eigen::VectorXd r = -b;
    solver_->solve(r, &z_mat);
    Eigen::VectorXd p = z_mat.col(0);
    if (pcg_iterations == 0) {
      *x = p;  // the plain chord step
      return true;
    }
    x->setZero(n);
    Eigen::VectorXd ap(n);
    const double b_norm = b.norm();
    const double target = options_.chord_pcg_tolerance * b_norm;
    double rz = r.dot(p);
    std::string trace;
    for (int k = 0; k < pcg_iterations; ++k) {
      ++result.pcg_iterations;
      multiply(p, damping, &ap);
      const double pap = p.dot(ap);
      if (!(pap > 0.0) || !std::isfinite(pap)) return false;
      const double alpha = rz / pap;
      *x += alpha * p;
      r -= alpha * ap;
      const double r_norm = r.norm();
      if (options_.verbose) {
        trace += str(" ", std::setprecision(2), r_norm / b_norm);
        common::logInfo(str("pcg residual/|b|:", trace));
      }
      if (r_norm <= target) return true;
      solver_->solve(r, &z_mat);
      const double rz_next = r.dot(z_mat.col(0));
      p = z_mat.col(0) + (rz_next / rz) * p;
      rz = rz_next;
    }
    return false;
  };
  Eigen::VectorXd dx, hdx;
  while (n_vars > 0 && result.iterations < options_.max_iterations) {
    ++result.iterations;
    if (cost <= std::numeric_limits<double>::min()) {
      result.converged = true;
      result.termination = "zero cost";
      break;
    }
    bool chord = false;
    if (try_chord) {
      try_chord = false;
      phase = Clock::now();
      chord = pcg(lambda, &dx);
      result.time.solve += secondsSince(phase);
      if (!chord) {
        // H moved too far from the factor for this step size: ask for smaller steps before
        // the next attempt (MIT: two failed attempts after 49 % and 38 % decreases).
        ++result.chord_fallbacks;
        chord_max_change *= 0.5;
      }
    }
    if (!chord) {
      // Damped diagonal: H_ii + λ·max(H_ii, ε); the undamped values are restored after.
      s.diag_saved.resize(s.diag_entry.size());
      for (std::size_t i = 0; i < s.diag_entry.size(); ++i) {
        double& d = s.h.values[s.diag_entry[i]];
        s.diag_saved[i] = d;
        if (lm) d += lambda * std::max(d, 1e-6);
      }
      phase = Clock::now();
      const bool ok = solver_->factorize(s.h);
      ++result.factorizations;
      result.time.numeric += secondsSince(phase);
      for (std::size_t i = 0; i < s.diag_entry.size(); ++i) {
        s.h.values[s.diag_entry[i]] = s.diag_saved[i];
      }
      factor_lambda = lambda;
      factor_diag = s.diag_saved;
      if (!ok) {
        if (!lm) {
          result.termination = "H is not positive definite (an under-constrained node?); try lm";
          break;
        }
        lambda = lambda > 0.0 ? lambda * nu : options_.restart_lambda;
        nu *= 2.0;
        if (lambda > options_.max_lambda) {
          result.termination = "damping limit reached (H not positive definite)";
          break;
        }
        continue;
      }
      phase = Clock::now();
      rhs = -b;
      solver_->solve(rhs, &dx_mat);
      result.time.solve += secondsSince(phase);
      dx = dx_mat.col(0);
    }
    if (!dx.allFinite()) {
      result.termination = "the linear solve produced a non-finite step";
      break;
    }
    if (dx.norm() <= options_.step_tolerance * (stateNorm() + options_.step_tolerance)) {
      result.converged = true;
      result.termination = "step below tolerance";
      break;
    }
    const std::vector<Pose2> saved = statePoses();
    applyStep(dx);
    if (!lm) {
      phase = Clock::now();
      double new_chi2 = 0.0;
      const double new_cost = assemble(&new_chi2);
      result.time.assembly += secondsSince(phase);
      ++result.accepted_steps;
      const double change = std::abs(cost - new_cost) / cost;
      if (options_.verbose) {
        common::logInfo(str("gn ", result.iterations, ": cost ", new_cost, " chi2 ", new_chi2));
      }
      cost = new_cost;
      chi2 = new_chi2;
      if (change < options_.relative_chi2_tolerance) {
        result.converged = true;
        result.termination = "relative chi2 change below tolerance";
        break;
      }
      continue;
    }
    // Gain ratio against the quadratic model, L(0) − L(Δ) = −2bᵀΔ − ΔᵀHΔ; for a step that
    // solves (H + λD)Δ = −b exactly this is −bᵀΔ + λ ΔᵀDΔ. (A PCG chord step solved the
    // current system only approximately: its model decrease is evaluated with H.)
    // A plain chord step (no PCG) is exact for the reused factor's system: its model is
    // that one (with the current H, an overshooting step can even predict an increase).
    double predicted = 0.0;
    if (chord && pcg_iterations > 0) {
      multiply(dx, 0.0, &hdx);
      predicted = -2.0 * b.dot(dx) - dx.dot(hdx);
    } else {
      predicted = -b.dot(dx);
      for (std::size_t i = 0; i < factor_diag.size(); ++i) {
        predicted += factor_lambda * std::max(factor_diag[i], 1e-6) * dx[i] * dx[i];
      }
    }
    // When the model promises less than the tolerance we are at the optimum (this also
    // catches steps whose effect drowns in rounding): keep the step if it helped, then stop.
    const bool negligible = predicted <= options_.relative_chi2_tolerance * cost;
    phase = Clock::now();
    double trial_chi2 = 0.0;
    const double trial_cost = evaluate(&trial_chi2);
    result.time.evaluate += secondsSince(phase);
    const double rho = (cost - trial_cost) / std::max(predicted, 1e-300);
    if (options_.verbose) {
      common::logInfo(str("lm ", result.iterations, chord ? " (chord)" : "", " pcg ",
                          result.pcg_iterations, ": cost ", std::setprecision(12), cost, " -> ",
                          trial_cost, " lambda ", factor_lambda, " rho ", rho));
    }
    if (std::isfinite(trial_cost) && trial_cost < cost && rho > 0.0) {
      ++result.accepted_steps;
      const double change = (cost - trial_cost) / cost;
      if (chord) {
        ++result.chord_steps;  // λ belongs to the full steps' trust region: unchanged
      } else {
        lambda *= std::max(options_.lambda_decrease_limit, 1.0 - std::pow(2.0 * rho - 1.0, 3));
        if (lambda > 0.0) lambda = std::max(lambda, 1e-15);  // 0 stays Gauss-Newton
        nu = 2.0;
      }
      try_chord = options_.chord_min_ratio > 0.0 && rho > options_.chord_min_ratio &&
                  (chord || change < chord_max_change);
      phase = Clock::now();
      cost = assemble(&chi2);
      result.time.assembly += secondsSince(phase);
      if (change < options_.relative_chi2_tolerance) {
        result.converged = true;
        result.termination = "relative chi2 change below tolerance";
        break;
      }
    } else if (chord) {
      // The old factor no longer models the cost well: refactorise, λ unchanged.
      for (int k = 0; k < n_vars; ++k) graph.setPoseAt(s.node_of_var[k], saved[k]);
      continue;
    } else {
      for (int k = 0; k < n_vars; ++k) graph.setPoseAt(s.node_of_var[k], saved[k]);
      lambda = lambda > 0.0 ? lambda * nu : options_.restart_lambda;
      nu *= 2.0;
      if (lambda > options_.max_lambda) {
        result.converged = true;
        result.termination = "no further decrease (damping limit reached)";
        break;
      }
    }
    if (negligible) {
      result.converged = true;
      result.termination = "predicted chi2 decrease below tolerance";
      break;
    }
  }
  if (result.termination.empty()) result.termination = "iteration limit";

  result.final_cost = evaluate(&result.final_chi2);
  result.final_lambda = lambda;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const Edge& edge = edges[e];
    const RobustKernel& kernel = kernels[static_cast<int>(edge.kind)];
    if (!edge.enabled || kernel.type == RobustKernelType::kNone) continue;
    double rho, w;
    robustKernel(kernel, graph.edgeChi2(e), &rho, &w);
    if (w < options_.downweight_threshold) result.downweighted.push_back(e);
  }
  result.time.total = secondsSince(start);
  return result;
}

}  // namespace storey::graph
