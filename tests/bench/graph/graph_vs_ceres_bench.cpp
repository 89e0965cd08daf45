// storey's pose-graph optimiser against Ceres 2.1 (LM + SPARSE_NORMAL_CHOLESKY on
// SuiteSparse, analytic Jacobians of the same residual, one thread) on the shared pose
// graphs, from the file's guess and from chained odometry. Prints per run: χ² of both,
// iterations, wall time (best of --repeats) and the time ratio; then runs the registered
// Google Benchmark cases (storey only) if --benchmark_filter is given.
//
//   build/tests/bench/graph/bench_graph_vs_ceres [--repeats N] [--data DIR]
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <Eigen/Cholesky>
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
  return {graph.chi2(), r.iterations, r.time.total, r.converged};
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
  return {graph.chi2(), static_cast<int>(summary.iterations.size()) - 1,
          summary.total_time_in_seconds, summary.termination_type == ceres::CONVERGENCE};
}

template <typename F>
Run best(const F& f, int repeats) {
  Run out = f();
  for (int k = 1; k < repeats; ++k) {
    const Run r = f();
    if (r.seconds < out.seconds) out = r;
  }
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
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--data") && i + 1 < argc) {
      data = argv[++i];
    } else {
      filter = filter || !std::strncmp(argv[i], "--benchmark_filter", 18);
      rest.push_back(argv[i]);
    }
  }
  std::printf(
      "storey: default options ('given'), initialization auto ('auto'), or\n"
      "orientation_first ('+orient.'); initialisation time included. Ceres: from the\n"
      "given guess, or ('orient.') from the same orientation-first poses (that\n"
      "initialisation's time excluded).\n");
  std::printf("%-15s %-9s %-9s | %14s %4s %9s | %-8s %14s %4s %9s | %8s %10s\n", "file", "init",
              "storey", "storey chi2", "it", "time[s]", "ceres", "ceres chi2", "it", "time[s]",
              "speedup", "rel.diff");
  auto row = [](const Case& c, const char* storey_mode, const Run& s, const char* ceres_mode,
                const Run& r) {
    std::printf(
        "%-15s %-9s %-9s | %14.6f %4d %9.4f | %-8s %14.6f %4d %9.4f | %7.2fx %10.2e%s\n", c.file,
        c.odometry ? "odometry" : "file", storey_mode, s.chi2, s.iterations, s.seconds, ceres_mode,
        r.chi2, r.iterations, r.seconds, r.seconds / s.seconds, (s.chi2 - r.chi2) / r.chi2,
        r.converged ? "" : (s.converged ? " (ceres not converged)" : " (neither converged)"));
    std::fflush(stdout);
  };
  for (const Case& c : kCases) {
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
    const Run s = best([&] { return runStorey(graph); }, repeats);
    const Run r = best([&] { return runCeres(graph); }, repeats);
    row(c, "given", s, "given", r);
    const Run sa = best([&] { return runStorey(graph, Initialization::kAuto); }, repeats);
    row(c, "auto", sa, "given", r);
    const Run so =
        best([&] { return runStorey(graph, Initialization::kOrientationFirst); }, repeats);
    PoseGraph oriented = graph;
    initializeOrientationFirst(oriented);
    const Run ro = best([&] { return runCeres(oriented); }, repeats);
    row(c, "+orient.", so, "orient.", ro);
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
