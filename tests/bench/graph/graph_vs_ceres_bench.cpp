// storey's pose-graph optimiser against Ceres 2.1 (LM + SPARSE_NORMAL_CHOLESKY on
// SuiteSparse, analytic Jacobians of the same residual, one thread) on the shared pose
// graphs, from the file's guess and from chained odometry. Prints per run: χ² of both,
// iterations, factorisations, wall time (best of --repeats, the two solvers alternating),
// the ratio of the best times and the median of the per-pair ratios, and storey's time per
// phase; then runs the registered Google Benchmark cases (storey only) if
// --benchmark_filter is given.
//
//   build/tests/bench/graph/bench_graph_vs_ceres [--repeats N] [--only city] [--data DIR]
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "storey/graph/graph_io.h"
#include "storey/graph/optimizer.h"

namespace {

using storey::geometry::Pose2;
using namespace storey::graph;

class RelativePoseCost : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  RelativePoseCost(const Pose2& z, const Eigen::Matrix3d& information) : z_(z) {
    // Ω = L Lᵀ, so eᵀΩe = ‖Lᵀe‖².
    sqrt_information_ = Eigen::LLT<Eigen::Matrix3d>(information).matrixL().transpose();
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Pose2 xi(p[0][0], p[0][1], p[0][2]), xj(p[1][0], p[1][1], p[1][2]);
    Eigen::Matrix3d ji, jj;
    const bool want = jacobians != nullptr;
    const Eigen::Vector3d e = edgeResidual(xi, xj, z_, want ? &ji : nullptr, want ? &jj : nullptr);
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r = sqrt_information_ * e;
    using RowMajor = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
    if (want && jacobians[0]) {
      Eigen::Map<RowMajor> d_xi(jacobians[0]);
      d_xi = sqrt_information_ * ji;
    }
    if (want && jacobians[1]) {
      Eigen::Map<RowMajor> d_xj(jacobians[1]);
      d_xj = sqrt_information_ * jj;
    }
    return true;
  }

 private:
  Pose2 z_;
  Eigen::Matrix3d sqrt_information_;
};

struct Run {
  double chi2 = 0.0;
  int iterations = 0;
  double seconds = 0.0;
  bool converged = false;
  int factorizations = 0;
  PhaseTimes phases;  // storey only
};

PoseGraph loadGraph(const std::string& path, bool odometry) {
  GraphReadInfo info;
  PoseGraph graph = readGraph(path, &info);
  if (odometry && !info.initialized_from_odometry) initializeFromOdometry(graph);
  return graph;
}

Run runStorey(PoseGraph graph, Initialization init = Initialization::kNone) {
  OptimizerOptions options;
  options.initialization = init;
  Optimizer optimizer(options);
  const OptimizerResult r = optimizer.optimize(graph);
  return {graph.chi2(), r.iterations, r.time.total, r.converged, r.factorizations, r.time};
}

Run runCeres(PoseGraph graph) {
  std::vector<std::array<double, 3>> x(graph.numNodes());
  for (std::size_t i = 0; i < graph.numNodes(); ++i) {
    const Pose2& p = graph.nodes()[i].pose;
    x[i] = {p.x(), p.y(), p.theta()};
  }
  ceres::Problem problem;
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    const Edge& edge = graph.edges()[e];
    problem.AddResidualBlock(new RelativePoseCost(edge.measurement, edge.information), nullptr,
                             x[graph.edgeFromIndex(e)].data(), x[graph.edgeToIndex(e)].data());
  }
  problem.SetParameterBlockConstant(x[0].data());  // same gauge as storey: the first node
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.max_num_iterations = 100;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  for (std::size_t i = 0; i < graph.numNodes(); ++i) {
    graph.setPoseAt(i, Pose2(x[i][0], x[i][1], x[i][2]));
  }
  Run run;
  run.chi2 = graph.chi2();
  run.iterations = static_cast<int>(summary.iterations.size()) - 1;
  run.seconds = summary.total_time_in_seconds;
  run.converged = summary.termination_type == ceres::CONVERGENCE;
  run.factorizations = summary.num_linear_solves;
  return run;
}

// Both solvers run alternately (storey, Ceres, storey, ...) so that a change of machine load
// hits both; reported: the best time of each and the median of the per-pair time ratios.
// Small graphs (a few ms per run, where one preemption decides a ratio) get more pairs:
// at least `repeats`, and more until Ceres has run 1 s in total, at most 10 × repeats.
struct Comparison {
  Run storey, ceres;  // the fastest run of each
  double median_ratio = 0.0;
  int pairs = 0;
};

template <typename S, typename C>
Comparison compare(const S& storey, const C& ceres, int repeats) {
  Comparison out;
  std::vector<double> ratios;
  double ceres_total = 0.0;
  for (int k = 0; k < 10 * repeats && (k < repeats || ceres_total < 1.0); ++k) {
    const Run s = storey();
    const Run c = ceres();
    ceres_total += c.seconds;
    if (k == 0 || s.seconds < out.storey.seconds) out.storey = s;
    if (k == 0 || c.seconds < out.ceres.seconds) out.ceres = c;
    ratios.push_back(c.seconds / s.seconds);
  }
  std::sort(ratios.begin(), ratios.end());
  const std::size_t m = ratios.size();
  out.median_ratio = m % 2 ? ratios[m / 2] : 0.5 * (ratios[m / 2 - 1] + ratios[m / 2]);
  out.pairs = static_cast<int>(m);
  return out;
}

struct Case {
  const char* file;
  bool odometry;
};
const Case kCases[] = {{"intel.g2o", false},     {"intel.g2o", true},     {"manhattan.g2o", true},
                       {"city10000.g2o", false}, {"city10000.g2o", true}, {"MIT.g2o", false},
                       {"MIT.g2o", true}};

void BM_StoreyOptimize(benchmark::State& state, std::string path, bool odometry) {
  const PoseGraph graph = loadGraph(path, odometry);
  for (auto _ : state) {
    const Run r = runStorey(graph);
    benchmark::DoNotOptimize(r.chi2);
    state.counters["chi2"] = r.chi2;
    state.counters["iterations"] = r.iterations;
  }
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 3;
  std::string data = std::string(STOREY_SHARED_DATA_DIR) + "/posegraph";
  std::vector<char*> rest{argv[0]};
  bool filter = false;
  std::string only;  // run only the files whose name contains this
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) {
      only = argv[++i];
    } else if (!std::strcmp(argv[i], "--data") && i + 1 < argc) {
      data = argv[++i];
    } else {
      filter = filter || !std::strncmp(argv[i], "--benchmark_filter", 18);
      rest.push_back(argv[i]);
    }
  }
  std::printf(
      "storey: option initialization none (the library default), auto (the default of\n"
      "storey optimize) or orientation_first ('orient.'); initialisation time included.\n"
      "Ceres: from the\n"
      "given guess, or ('orient.') from the same orientation-first poses (that\n"
      "initialisation's time excluded). Runs alternate storey/Ceres, at least %d pairs\n"
      "(more until Ceres ran 1 s); times are the best of each, 'median' is the median of\n"
      "the per-pair ratios Ceres/storey.\n"
      "f: numeric factorisations (Ceres: linear solves).\n",
      repeats);
  std::printf("%-15s %-9s %-9s | %14s %3s %3s %8s | %-8s %14s %3s %3s %8s | %7s %7s %9s\n", "file",
              "init", "storey", "storey chi2", "it", "f", "time[s]", "ceres", "ceres chi2", "it",
              "f", "time[s]", "best", "median", "rel.diff");
  auto row = [](const Case& c, const char* storey_mode, const char* ceres_mode,
                const Comparison& cmp) {
    const Run& s = cmp.storey;
    const Run& r = cmp.ceres;
    std::printf(
        "%-15s %-9s %-9s | %14.6f %3d %3d %8.4f | %-8s %14.6f %3d %3d %8.4f | %6.2fx %6.2fx "
        "%9.2e%s\n",
        c.file, c.odometry ? "odometry" : "file", storey_mode, s.chi2, s.iterations,
        s.factorizations, s.seconds, ceres_mode, r.chi2, r.iterations, r.factorizations, r.seconds,
        r.seconds / s.seconds, cmp.median_ratio, (s.chi2 - r.chi2) / r.chi2,
        r.converged ? "" : (s.converged ? " (ceres not converged)" : " (neither converged)"));
    const PhaseTimes& t = s.phases;
    std::printf(
        "%-15s   storey phases [ms]: init %.1f symbolic %.1f assembly %.1f numeric %.1f "
        "solve %.1f evaluate %.1f other %.1f; %d pairs\n",
        "", 1e3 * t.initialization, 1e3 * t.symbolic, 1e3 * t.assembly, 1e3 * t.numeric,
        1e3 * t.solve, 1e3 * t.evaluate,
        1e3 * (t.total - t.initialization - t.symbolic - t.assembly - t.numeric - t.solve -
               t.evaluate),
        cmp.pairs);
    std::fflush(stdout);
  };
  for (const Case& c : kCases) {
    if (!only.empty() && std::string(c.file).find(only) == std::string::npos) continue;
    const std::string path = data + "/" + c.file;
    if (!std::fopen(path.c_str(), "r")) {
      std::printf("%-15s skipped: %s is absent\n", c.file, path.c_str());
      continue;
    }
    const PoseGraph graph = loadGraph(path, c.odometry);
    const bool has_vertices = [&] {
      GraphReadInfo info;
      readGraph(path, &info);
      return info.vertices > 0;
    }();
    if (!c.odometry && !has_vertices) continue;
    auto ceres_given = [&] { return runCeres(graph); };
    row(c, "none", "given", compare([&] { return runStorey(graph); }, ceres_given, repeats));
    row(c, "auto", "given",
        compare([&] { return runStorey(graph, Initialization::kAuto); }, ceres_given, repeats));
    PoseGraph oriented = graph;
    initializeOrientationFirst(oriented);
    row(c, "orient.", "orient.",
        compare([&] { return runStorey(graph, Initialization::kOrientationFirst); },
                [&] { return runCeres(oriented); }, repeats));
    benchmark::RegisterBenchmark(
        (std::string("storey/") + c.file + (c.odometry ? "/odometry" : "/file")).c_str(),
        BM_StoreyOptimize, path, c.odometry)
        ->Unit(benchmark::kMillisecond);
  }
  if (filter) {
    int n = static_cast<int>(rest.size());
    benchmark::Initialize(&n, rest.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
  }
  return 0;
}
