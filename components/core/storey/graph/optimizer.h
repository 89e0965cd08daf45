// Sparse Gauss-Newton / Levenberg-Marquardt for PoseGraph.
//
// The normal equations H Δ = −b are assembled straight into the upper triangle of a
// compressed sparse column matrix whose pattern and per-edge write positions are computed
// once per graph structure (PoseGraph::structureVersion()); the linear solver analyses the
// pattern once and then only refactorises numerically. Adding nodes/edges or changing a
// fixed flag re-analyses; moving poses or enabling/disabling edges does not.
//
// Gauge: fixed nodes are constants. With gauge "first_node", a graph with no fixed node
// gets its first node fixed, and any connected component still without a fixed node is an
// error naming it; with gauge "per_component" each such component gets its first node
// fixed (reported in OptimizerResult::auto_fixed).
#pragma once

#include <Eigen/Core>
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/graph/initialization.h"
#include "storey/graph/linear_solver.h"
#include "storey/graph/pose_graph.h"

namespace storey::graph {

enum class Algorithm { kGaussNewton, kLevenbergMarquardt };
enum class RobustKernelType { kNone, kHuber, kCauchy, kDcs };
enum class GaugeMode { kFirstNode, kPerComponent };
// kOrientationFirst replaces the free poses by initializeOrientationFirst() before iterating
// (initialization.h): for a poor start (odometry, MIT's file guess); not for robust runs
// (false closures corrupt it) nor for re-optimising from a previous estimate.
// kAuto does so when no robust kernel is set and the given poses' χ² per enabled edge
// exceeds auto_initialization_chi2 (an optimum has about 3 per edge).
enum class Initialization { kNone, kOrientationFirst, kAuto };

// A kernel ρ applied to an edge's squared error s = eᵀΩe. `delta` is the Huber/Cauchy
// width (in units of √s) or the DCS Φ.
struct RobustKernel {
  RobustKernelType type = RobustKernelType::kNone;
  double delta = 1.0;
};
const char* robustKernelName(RobustKernelType type);          // "none", "huber", "cauchy", "dcs"
RobustKernelType parseRobustKernel(const std::string& name);  // throws std::invalid_argument
// ρ(s) and the IRLS weight w = ρ'(s) (for DCS: the squared scaling factor).
void robustKernel(const RobustKernel& kernel, double s, double* rho, double* weight);

struct OptimizerOptions {
  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  // "cholmod", "cholmod_supernodal", "cholmod_nd" or "eigen" (linear_solver.h).
  std::string linear_solver = "cholmod";
  int max_iterations = 100;  // accepted + rejected steps
  // Stop when |Δχ²| / χ² of an accepted step falls below this (Ceres's default function
  // tolerance; on intel, manhattan and city10000 it stops within 2e-7 of the optimum).
  double relative_chi2_tolerance = 1e-6;
  // Stop when ‖Δ‖ < step_tolerance · (‖x‖ + step_tolerance).
  double step_tolerance = 1e-10;
  // LM damping: (H + λ·diag(H)) Δ = −b, λ adapted by the gain ratio (Nielsen). λ = 0 starts
  // with undamped (Gauss-Newton) steps while they lower the cost; the first rejected step
  // sets λ = restart_lambda. On manhattan from odometry this took 5 steps where starting
  // at λ = 1e-5 took 27 (small damping bends the first step away from the Gauss-Newton one).
  double initial_lambda = 0.0;
  double restart_lambda = 1e-5;
  double max_lambda = 1e10;
  // After a good step λ shrinks by max(this, 1 − (2ρ − 1)³) (Nielsen's rule uses 1/3; 0.1
  // saved 1-3 steps on intel and city10000 and 30 on MIT, costing 5 on manhattan).
  double lambda_decrease_limit = 0.1;
  // LM chord steps: after a full step with gain ratio above chord_min_ratio that lowered
  // the cost by less than the fraction chord_max_change (near the optimum, where H changes
  // little), the next step reuses the last factorisation with the new gradient (one solve
  // instead of one factorisation) and is kept if it lowers the cost; another chord step
  // follows while their gain ratio stays above chord_min_ratio. Early in a solve the
  // rotations still move and a chord step explodes (city10000, manhattan: cost ×1e4-1e12),
  // hence the change limit. chord_min_ratio 0 disables them.
  double chord_min_ratio = 0.5;
  double chord_max_change = 0.5;
  // A chord step is refined by preconditioned conjugate gradients on the current damped
  // system (H + λD)Δ = −b, the reused factorisation as the preconditioner: at most
  // chord_pcg_iterations iterations (0: the plain chord step M⁻¹b), until the residual is
  // below chord_pcg_tolerance·‖b‖. When that fails the step is factorised after all. Near
  // the optimum this gives the Gauss-Newton step for a few solves where the plain chord
  // step often fails (city10000: one factorisation instead of two after the
  // orientation-first start).
  int chord_pcg_iterations = 8;
  double chord_pcg_tolerance = 1e-3;
  // PCG only pays where a factorisation costs many PCG iterations: it is used when the
  // analysis estimates a factorisation at ≥ chord_pcg_min_cost iterations (flops of one
  // solve plus one product with H); below, chord steps are plain (city10000: ~16, PCG;
  // manhattan ~6, intel ~3, MIT ~1: plain, 5–16 % faster there). 0: always PCG.
  double chord_pcg_min_cost = 8.0;
  GaugeMode gauge = GaugeMode::kFirstNode;
  Initialization initialization = Initialization::kNone;
  double auto_initialization_chi2 = 10.0;
  std::array<RobustKernel, kEdgeKindCount> robust{};  // indexed by EdgeKind
  // Edges whose final robust weight is below this are reported as down-weighted.
  double downweight_threshold = 0.5;
  bool verbose = false;  // log every iteration
};

// Reads, strictly (unknown keys fail), e.g.
//   algorithm: lm            # gn | lm
//   linear_solver: cholmod   # cholmod | cholmod_supernodal | cholmod_nd | eigen
//   max_iterations: 100
//   relative_chi2_tolerance: 1e-6
//   step_tolerance: 1e-10
//   initial_lambda: 0
//   restart_lambda: 1e-5
//   max_lambda: 1e10
//   lambda_decrease_limit: 0.1
//   chord_min_ratio: 0.5
//   chord_max_change: 0.5
//   chord_pcg_iterations: 8
//   chord_pcg_tolerance: 1e-3
//   chord_pcg_min_cost: 8
//   gauge: first_node        # first_node | per_component
//   initialization: none     # none | orientation_first | auto
//   auto_initialization_chi2: 10
//   downweight_threshold: 0.5
//   verbose: false
//   robust:                  # per edge kind
//     loop_closure: {kernel: dcs, delta: 1.0}
// Every key is optional; an absent key keeps its value in `base` (an absent robust kind
// keeps base's kernel).
OptimizerOptions readOptimizerOptions(const common::ConfigNode& config,
                                      OptimizerOptions base = OptimizerOptions());

struct PhaseTimes {
  double initialization = 0.0;  // orientation-first initialisation, when chosen
  double assembly = 0.0;        // residuals, Jacobians, H and b (seconds)
  double symbolic = 0.0;        // structure, ordering, symbolic factorisation
  double numeric = 0.0;         // numeric factorisations
  double solve = 0.0;           // triangular solves
  double evaluate = 0.0;        // χ² of trial steps (LM)
  double total = 0.0;
};

struct OptimizerResult {
  bool converged = false;
  std::string termination;        // why it stopped
  double initial_chi2 = 0.0;      // Σ eᵀΩe of enabled edges (no kernel), at the given poses
  double initialized_chi2 = 0.0;  // after the initialisation (= initial_chi2 without one)
  bool initialized = false;       // the orientation-first initialisation ran
  double final_chi2 = 0.0;
  double initial_cost = 0.0;  // Σ ρ(eᵀΩe): the robust objective actually minimised
  double final_cost = 0.0;
  int iterations = 0;  // steps tried
  int accepted_steps = 0;
  int factorizations = 0;
  int chord_steps = 0;      // accepted steps that reused the previous factorisation
  int pcg_iterations = 0;   // conjugate-gradient iterations of the chord steps (all tried)
  bool pcg_used = false;    // chord steps were PCG-refined (else plain; chord_pcg_min_cost)
  int chord_fallbacks = 0;  // chord steps whose PCG did not converge (then factorised)
  bool reanalysed = false;  // the structure was (re)analysed in this call
  double final_lambda = 0.0;
  PhaseTimes time;
  int components = 0;                     // connected components over enabled edges
  std::vector<NodeId> auto_fixed;         // nodes fixed by the gauge rule
  std::vector<std::size_t> downweighted;  // edge indices with weight < threshold
};

class Optimizer {
 public:
  explicit Optimizer(OptimizerOptions options = {});
  ~Optimizer();
  Optimizer(Optimizer&&) noexcept;
  Optimizer& operator=(Optimizer&&) noexcept;

  // Optimises the graph in place from its current poses. Throws GraphError for a gauge
  // problem (a component with no fixed node under gauge first_node) or an empty graph.
  OptimizerResult optimize(PoseGraph& graph);

  // Marginal covariances (3×3, of x, y, θ) of the given nodes at the graph's current poses,
  // from a factorisation of H at those poses (solving for the nodes' columns only; no dense
  // inverse). Fixed nodes get zero. Call after optimize() on the same graph (reuses its
  // analysed structure). Throws GraphError for unknown ids or a singular H.
  std::map<NodeId, Eigen::Matrix3d> marginalCovariances(const PoseGraph& graph,
                                                        const std::vector<NodeId>& ids);

  const OptimizerOptions& options() const { return options_; }
  void setOptions(const OptimizerOptions& options);

 private:
  struct Structure;
  OptimizerOptions options_;
  std::unique_ptr<Structure> structure_;
  std::unique_ptr<LinearSolver> solver_;
};

}  // namespace storey::graph
