// storey optimize IN OUT: reads a g2o/TORO pose graph, optimises it and writes the result.
#include <iomanip>
#include <iostream>

#include "args.h"
#include "storey/common/config.h"
#include "storey/graph/graph_io.h"
#include "storey/graph/optimizer.h"

namespace storey::cli {

extern const char* const summary_optimize = "optimise a g2o/TORO pose graph (GN/LM on CHOLMOD)";

int run_optimize(Args& args) {
  args.usage("IN.g2o OUT.g2o",
             "Reads a pose graph (g2o, or TORO for .graph/.toro), optimises it and writes it.\n"
             "Prints the initial and final chi2, the iterations and the time per phase.")
      .option("init", "file|odometry|orientation|auto",
              "start: the file's vertices or chained odometry from the first node ('orientation' "
              "and 'auto' are the file's vertices with --initialization orientation_first or "
              "auto)",
              "file")
      .option("initialization", "auto|orientation_first|none",
              "orientation-first estimate before iterating: when the start is poor (chi2 per "
              "edge > 10) and no robust kernel is set, always, or never (the library's default "
              "for incremental use is none; a --config file's value applies unless this is "
              "given)",
              "auto")
      .option("solver", "gn|lm", "Gauss-Newton or Levenberg-Marquardt", "lm")
      .option("robust", "none|huber|cauchy|dcs",
              "robust kernel on every non-odometry edge (scan match, loop closure, inter-floor)",
              "none")
      .option("delta", "D", "robust kernel width (Huber/Cauchy) or DCS Phi", "1")
      .option("iterations", "N", "iteration cap", "100")
      .option("linear-solver", "cholmod|cholmod_supernodal|cholmod_nd|eigen",
              "sparse Cholesky backend (cholmod_nd: supernodal, METIS ordering)", "cholmod")
      .option("config", "FILE", "optimizer options (YAML); overrides the options above")
      .flag("per-component", "fix the first node of every connected component lacking one")
      .flag("verbose", "log every iteration");
  if (!args.parse()) return 0;
  const std::string in = args.positional(0, "IN");
  const std::string out = args.positional(1, "OUT");

  graph::OptimizerOptions options;
  const std::string solver = args.get("solver");
  if (solver != "gn" && solver != "lm") throw UsageError("--solver must be gn or lm");
  options.algorithm =
      solver == "gn" ? graph::Algorithm::kGaussNewton : graph::Algorithm::kLevenbergMarquardt;
  graph::RobustKernel kernel;
  try {
    kernel.type = graph::parseRobustKernel(args.get("robust"));
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string("--robust: ") + error.what());
  }
  kernel.delta = args.getDouble("delta");
  if (!(kernel.delta > 0.0)) throw UsageError("--delta must be positive");
  for (graph::EdgeKind kind :
       {graph::EdgeKind::kScanMatch, graph::EdgeKind::kLoopClosure, graph::EdgeKind::kInterFloor}) {
    options.robust[static_cast<int>(kind)] = kernel;
  }
  const long iterations = args.getInt("iterations");
  if (iterations < 1) throw UsageError("--iterations must be at least 1");
  options.max_iterations = static_cast<int>(iterations);
  options.linear_solver = args.get("linear-solver");
  if (options.linear_solver != "cholmod" && options.linear_solver != "cholmod_supernodal" &&
      options.linear_solver != "cholmod_nd" && options.linear_solver != "eigen") {
    throw UsageError("--linear-solver must be cholmod, cholmod_supernodal, cholmod_nd or eigen");
  }
  if (args.flagSet("per-component")) options.gauge = graph::GaugeMode::kPerComponent;
  options.verbose = args.flagSet("verbose");
  if (args.has("config")) {
    options = graph::readOptimizerOptions(common::ConfigNode::loadFile(args.get("config")));
  }
  const std::string init = args.get("init");
  if (init != "file" && init != "odometry" && init != "orientation" && init != "auto") {
    throw UsageError("--init must be file, odometry, orientation or auto");
  }
  const std::string initialization = args.get("initialization");
  if (initialization != "auto" && initialization != "orientation_first" &&
      initialization != "none") {
    throw UsageError("--initialization must be auto, orientation_first or none");
  }
  if (!args.has("config") || args.has("initialization")) {
    options.initialization = initialization == "auto"   ? graph::Initialization::kAuto
                             : initialization == "none" ? graph::Initialization::kNone
                                                        : graph::Initialization::kOrientationFirst;
  }
  if (init == "orientation") options.initialization = graph::Initialization::kOrientationFirst;
  if (init == "auto") options.initialization = graph::Initialization::kAuto;

  graph::GraphReadInfo info;
  graph::PoseGraph pose_graph = graph::readGraph(in, &info);
  if (init == "odometry" && !info.initialized_from_odometry) {
    graph::initializeFromOdometry(pose_graph);
  }
  std::cout << "read " << in << ": " << pose_graph.numNodes() << " nodes, " << pose_graph.numEdges()
            << " edges"
            << (info.initialized_from_odometry ? " (no vertices: chained odometry guess)" : "")
            << "\n";

  graph::Optimizer optimizer(options);
  const graph::OptimizerResult r = optimizer.optimize(pose_graph);
  std::cout << std::setprecision(9);
  std::cout << "initial chi2 " << r.initial_chi2 << "\n"
            << "final chi2   " << r.final_chi2 << "\n";
  if (r.final_cost != r.final_chi2) {
    std::cout << "robust cost  " << r.initial_cost << " -> " << r.final_cost << "\n";
  }
  std::cout << "iterations " << r.iterations << " (accepted " << r.accepted_steps
            << ", factorisations " << r.factorizations << ", chord steps " << r.chord_steps
            << " with " << r.pcg_iterations << " PCG iterations), "
            << (r.converged ? "converged: " : "not converged: ") << r.termination << "\n";
  std::cout << std::setprecision(3) << std::fixed;
  if (r.initialized) {
    std::cout << "orientation-first initialisation: chi2 " << r.initialized_chi2 << "\n";
  }
  std::cout << "time [ms]: initialisation " << 1e3 * r.time.initialization << ", assembly "
            << 1e3 * r.time.assembly << ", symbolic " << 1e3 * r.time.symbolic << ", numeric "
            << 1e3 * r.time.numeric << ", solve " << 1e3 * r.time.solve << ", evaluate "
            << 1e3 * r.time.evaluate << ", total " << 1e3 * r.time.total << "\n";
  if (!r.auto_fixed.empty()) {
    std::cout << "gauge: fixed node(s)";
    for (graph::NodeId id : r.auto_fixed) std::cout << ' ' << id;
    std::cout << " (" << r.components << " component(s))\n";
  }
  if (!r.downweighted.empty()) {
    std::cout << r.downweighted.size() << " edge(s) down-weighted by the robust kernel:";
    std::size_t shown = 0;
    for (std::size_t e : r.downweighted) {
      if (++shown > 50) {
        std::cout << " ...";
        break;
      }
      const graph::Edge& edge = pose_graph.edges()[e];
      std::cout << ' ' << edge.from << "-" << edge.to;
    }
    std::cout << "\n";
  }
  graph::writeGraph(pose_graph, out);
  std::cout << "wrote " << out << "\n";
  return r.converged ? 0 : 2;
}

}  // namespace storey::cli
