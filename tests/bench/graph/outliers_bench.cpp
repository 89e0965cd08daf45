// Robustness to false loop closures: adds a seeded fraction (10 %, 30 % of the true loop
// closures) of random loop closures to intel (from the file's guess) and manhattan (from
// chained odometry), optimises with a robust kernel on loop closures, and prints the largest
// pose error against the outlier-free optimum and how many of the down-weighted edges are
// the false ones.
//
//   build/tests/bench/graph/bench_graph_outliers [--kernel dcs] [--delta 1] [--seed 7]
//                                                [--data DIR]
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "false_loop_closures.h"
#include "storey/graph/graph_io.h"
#include "storey/graph/optimizer.h"

using namespace storey::graph;
using storey::geometry::Pose2;
using storey::test::addFalseLoopClosures;

int main(int argc, char** argv) {
  std::string data = std::string(STOREY_SHARED_DATA_DIR) + "/posegraph";
  RobustKernel kernel{RobustKernelType::kDcs, 1.0};
  unsigned seed = 7;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--kernel")) {
      kernel.type = parseRobustKernel(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--delta")) {
      kernel.delta = std::atof(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--seed")) {
      seed = static_cast<unsigned>(std::atoi(argv[i + 1]));
    } else if (!std::strcmp(argv[i], "--data")) {
      data = argv[i + 1];
    }
  }
  std::printf("kernel %s, delta %g, seed %u\n", robustKernelName(kernel.type), kernel.delta, seed);
  std::printf("%-14s %-9s %5s | %6s | %10s %9s | %6s %6s | %4s %8s  %s\n", "file", "init", "false",
              "edges", "max xy[m]", "max th[°]", "downw.", "false", "it", "time[s]",
              "within 0.1 m / 1°");
  struct Case {
    const char* file;
    bool odometry;
  };
  for (const Case c : {Case{"intel.g2o", false}, Case{"manhattan.g2o", true}}) {
    const std::string path = data + "/" + c.file;
    GraphReadInfo info;
    PoseGraph original;
    try {
      original = readGraph(path, &info);
    } catch (const std::exception& error) {
      std::printf("%s skipped: %s\n", c.file, error.what());
      continue;
    }
    if (c.odometry && !info.initialized_from_odometry) initializeFromOdometry(original);
    PoseGraph clean = original;
    Optimizer().optimize(clean);
    for (double fraction : {0.1, 0.3}) {
      PoseGraph graph = original;
      const std::set<std::size_t> false_edges = addFalseLoopClosures(&graph, fraction, seed);
      OptimizerOptions options;
      options.robust[static_cast<int>(EdgeKind::kLoopClosure)] = kernel;
      options.max_iterations = 200;
      const OptimizerResult r = Optimizer(options).optimize(graph);
      benchmark::DoNotOptimize(r.final_chi2);
      double worst_xy = 0.0, worst_theta = 0.0;
      for (std::size_t i = 0; i < clean.numNodes(); ++i) {
        const Pose2& p = graph.nodes()[i].pose;
        const Pose2& q = clean.nodes()[i].pose;
        worst_xy = std::max(worst_xy, (p.translation() - q.translation()).norm());
        worst_theta =
            std::max(worst_theta, std::abs(storey::geometry::angleDiff(p.theta(), q.theta())));
      }
      std::size_t named_false = 0;
      for (std::size_t e : r.downweighted) named_false += false_edges.count(e);
      const bool ok = worst_xy < 0.1 && worst_theta < M_PI / 180.0;
      std::printf("%-14s %-9s %4.0f%% | %6zu | %10.4f %9.4f | %6zu %6zu | %4d %8.3f  %s\n", c.file,
                  c.odometry ? "odometry" : "file", 100 * fraction, false_edges.size(), worst_xy,
                  worst_theta * 180.0 / M_PI, r.downweighted.size(), named_false, r.iterations,
                  r.time.total, ok ? "yes" : "NO");
      std::fflush(stdout);
    }
  }
  return 0;
}
