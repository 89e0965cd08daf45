#include "storey/graph/optimizer.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <set>

#include "storey/common/config.h"
#include "synthetic_graph.h"
#include "test_support.h"

namespace storey::graph {
namespace {

using geometry::Pose2;

double maxPoseDistance(const PoseGraph& a, const PoseGraph& b, double* max_angle) {
  double worst = 0.0;
  *max_angle = 0.0;
  for (std::size_t i = 0; i < a.numNodes(); ++i) {
    const Pose2& p = a.nodes()[i].pose;
    const Pose2& q = b.nodes()[i].pose;
    worst = std::max(worst, (p.translation() - q.translation()).norm());
    *max_angle = std::max(*max_angle, std::abs(geometry::angleDiff(p.theta(), q.theta())));
  }
  return worst;
}

TEST(Optimizer, GaussNewtonAndLevenbergMarquardtAgreeOnBothBackends) {
  const testing::Synthetic s = testing::makeLaps(3, 6, 0.05, 0.02, 11);
  std::vector<PoseGraph> results;
  for (Algorithm algorithm : {Algorithm::kGaussNewton, Algorithm::kLevenbergMarquardt}) {
    for (const char* backend : {"cholmod", "cholmod_supernodal", "cholmod_nd", "eigen"}) {
      PoseGraph g = s.graph;
      OptimizerOptions options;
      options.algorithm = algorithm;
      options.linear_solver = backend;
      options.relative_chi2_tolerance = 1e-12;  // compare the optima, not the stopping points
      const OptimizerResult r = Optimizer(options).optimize(g);
      EXPECT_TRUE(r.converged) << r.termination;
      EXPECT_LT(r.final_chi2, r.initial_chi2);
      EXPECT_NEAR(r.final_chi2, g.chi2(), 1e-9 * r.final_chi2);
      EXPECT_EQ(r.auto_fixed, std::vector<NodeId>{0});
      results.push_back(g);
    }
  }
  for (std::size_t k = 1; k < results.size(); ++k) {
    double angle = 0.0;
    EXPECT_LT(maxPoseDistance(results[0], results[k], &angle), 1e-6);
    EXPECT_LT(angle, 1e-7);
    EXPECT_NEAR(results[k].chi2(), results[0].chi2(), 1e-8 * results[0].chi2());
  }
  // The optimum is close to the truth (noise 5 cm per step over 72 steps, loops closed).
  double angle = 0.0;
  PoseGraph truth = s.graph;
  for (std::size_t i = 0; i < s.truth.size(); ++i) truth.setPoseAt(i, s.truth[i]);
  EXPECT_LT(maxPoseDistance(results[0], truth, &angle), 0.5);
}

TEST(Optimizer, OptimumIsStationary) {
  testing::Synthetic s = testing::makeLaps(2, 5, 0.05, 0.02, 4);
  Optimizer optimizer;
  optimizer.optimize(s.graph);
  const double best = s.graph.chi2();
  // Any small move of any free coordinate increases χ².
  for (std::size_t i = 1; i < s.graph.numNodes(); i += 3) {
    for (int c = 0; c < 3; ++c) {
      for (double h : {-1e-4, 1e-4}) {
        PoseGraph g = s.graph;
        Eigen::Vector3d v = g.nodes()[i].pose.vector();
        v[c] += h;
        g.setPoseAt(i, Pose2(v));
        EXPECT_GT(g.chi2(), best - 1e-9 * best) << "node " << i << " coordinate " << c;
      }
    }
  }
}

TEST(Optimizer, LevenbergMarquardtConvergesFromAPoorStart) {
  testing::Synthetic s = testing::makeLaps(3, 8, 0.05, 0.02, 21);
  PoseGraph reference = s.graph;
  Optimizer().optimize(reference);
  // Odometry integrated with a heading bias of 3° per step: the laps spiral apart.
  PoseGraph g = s.graph;
  for (std::size_t i = 1; i < g.numNodes(); ++i) {
    const Pose2 step = g.edges()[i - 1].measurement * Pose2(0, 0, 3.0 * M_PI / 180.0);
    g.setPoseAt(i, g.nodes()[i - 1].pose * step);
  }
  const OptimizerResult r = Optimizer().optimize(g);
  EXPECT_TRUE(r.converged) << r.termination;
  EXPECT_NEAR(r.final_chi2, reference.chi2(), 1e-6 * reference.chi2())
      << "initial " << r.initial_chi2 << " iterations " << r.iterations << " " << r.termination;
}

TEST(Optimizer, ChordStepsReachTheSameOptimumWithFewerFactorizations) {
  const testing::Synthetic s = testing::makeLaps(4, 8, 0.05, 0.02, 21);
  OptimizerOptions with;
  OptimizerOptions without;
  without.chord_min_ratio = 0.0;
  PoseGraph a = s.graph, b = s.graph;
  const OptimizerResult ra = Optimizer(with).optimize(a);
  const OptimizerResult rb = Optimizer(without).optimize(b);
  ASSERT_TRUE(ra.converged) << ra.termination;
  ASSERT_TRUE(rb.converged) << rb.termination;
  EXPECT_EQ(rb.chord_steps, 0);
  EXPECT_GT(ra.chord_steps, 0);
  EXPECT_LT(ra.factorizations, rb.factorizations);
  EXPECT_NEAR(ra.final_chi2, rb.final_chi2, 1e-6 * rb.final_chi2);
  double angle = 0.0;
  EXPECT_LT(maxPoseDistance(a, b, &angle), 1e-3);
  EXPECT_LT(angle, 1e-4);
}

// Chord steps refined by conjugate gradients (the old factorisation as preconditioner)
// reach the optimum of plain factorised steps, with no more factorisations than plain
// chord steps.
TEST(Optimizer, PcgChordStepsReachTheSameOptimum) {
  const testing::Synthetic s = testing::makeLaps(5, 10, 0.05, 0.02, 33);
  OptimizerOptions none, plain, pcg;
  none.chord_min_ratio = 0.0;
  plain.chord_pcg_iterations = 0;
  pcg.chord_pcg_iterations = 20;
  pcg.chord_pcg_tolerance = 1e-6;
  pcg.chord_pcg_min_cost = 0.0;  // this small graph's factorisation is cheap: force PCG
  PoseGraph a = s.graph, b = s.graph, c = s.graph;
  const OptimizerResult ra = Optimizer(none).optimize(a);
  const OptimizerResult rb = Optimizer(plain).optimize(b);
  const OptimizerResult rc = Optimizer(pcg).optimize(c);
  for (const OptimizerResult* r : {&ra, &rb, &rc}) ASSERT_TRUE(r->converged) << r->termination;
  EXPECT_EQ(rb.pcg_iterations, 0);
  EXPECT_TRUE(rc.pcg_used);
  EXPECT_GT(rc.chord_steps, 0);
  EXPECT_GT(rc.pcg_iterations, 0);
  EXPECT_LE(rc.factorizations, rb.factorizations);
  EXPECT_LT(rc.factorizations, ra.factorizations);
  EXPECT_NEAR(rc.final_chi2, ra.final_chi2, 1e-6 * ra.final_chi2);
  EXPECT_NEAR(rb.final_chi2, ra.final_chi2, 1e-6 * ra.final_chi2);
  double angle = 0.0;
  EXPECT_LT(maxPoseDistance(a, c, &angle), 1e-3);
  EXPECT_LT(angle, 1e-4);
}

// With the default cost rule a small graph (factorisation ≈ a few solves) uses plain chord
// steps; a high bar does so anywhere.
TEST(Optimizer, PcgOnlyWhereAFactorizationIsExpensive) {
  const testing::Synthetic s = testing::makeLaps(5, 10, 0.05, 0.02, 33);
  OptimizerOptions cheap;  // defaults
  OptimizerOptions forced;
  forced.chord_pcg_min_cost = 0.0;
  OptimizerOptions never;
  never.chord_pcg_min_cost = 1e9;
  PoseGraph a = s.graph, b = s.graph, c = s.graph;
  const OptimizerResult ra = Optimizer(cheap).optimize(a);
  const OptimizerResult rb = Optimizer(forced).optimize(b);
  const OptimizerResult rc = Optimizer(never).optimize(c);
  EXPECT_FALSE(ra.pcg_used);
  EXPECT_EQ(ra.pcg_iterations, 0);
  EXPECT_GT(ra.chord_steps, 0);
  EXPECT_TRUE(rb.pcg_used);
  EXPECT_FALSE(rc.pcg_used);
  EXPECT_NEAR(ra.final_chi2, rb.final_chi2, 1e-6 * rb.final_chi2);
}

// A PCG that cannot reach its tolerance within the cap falls back to a factorisation and
// still converges to the same optimum.
TEST(Optimizer, PcgChordFallsBackToAFactorization) {
  const testing::Synthetic s = testing::makeLaps(5, 10, 0.05, 0.02, 33);
  OptimizerOptions strict;
  strict.chord_pcg_iterations = 1;
  strict.chord_pcg_tolerance = 1e-12;
  strict.chord_pcg_min_cost = 0.0;
  OptimizerOptions none;
  none.chord_min_ratio = 0.0;
  PoseGraph a = s.graph, b = s.graph;
  const OptimizerResult ra = Optimizer(strict).optimize(a);
  const OptimizerResult rb = Optimizer(none).optimize(b);
  ASSERT_TRUE(ra.converged) << ra.termination;
  EXPECT_GT(ra.chord_fallbacks, 0);
  EXPECT_EQ(ra.chord_steps, 0);
  EXPECT_NEAR(ra.final_chi2, rb.final_chi2, 1e-9 * rb.final_chi2);
}

// One Gauss-Newton step of the optimiser (its own residual code) equals a dense step built
// from edgeResidual() and its Jacobians (checked numerically in residual_test.cpp), and its
// initial χ² equals PoseGraph::chi2().
TEST(Optimizer, StepMatchesADenseStepFromEdgeResidual) {
  const testing::Synthetic s = testing::makeLaps(2, 4, 0.05, 0.02, 8);
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int trial = 0; trial < 20; ++trial) {
    PoseGraph g = s.graph;
    for (std::size_t i = 1; i < g.numNodes(); ++i) {
      const Pose2& p = g.nodes()[i].pose;
      g.setPoseAt(i, Pose2(p.x() + noise(rng), p.y() + noise(rng), p.theta() + 3 * noise(rng)));
    }
    const int vars = static_cast<int>(g.numNodes()) - 1;  // node 0 is the gauge
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(3 * vars, 3 * vars);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(3 * vars);
    for (std::size_t e = 0; e < g.numEdges(); ++e) {
      Eigen::Matrix3d ji, jj;
      const Eigen::Vector3d r =
          edgeResidual(g.nodes()[g.edgeFromIndex(e)].pose, g.nodes()[g.edgeToIndex(e)].pose,
                       g.edges()[e].measurement, &ji, &jj);
      const Eigen::Matrix3d& omega = g.edges()[e].information;
      const int index[2] = {static_cast<int>(g.edgeFromIndex(e)) - 1,
                            static_cast<int>(g.edgeToIndex(e)) - 1};
      const Eigen::Matrix3d* jac[2] = {&ji, &jj};
      for (int p = 0; p < 2; ++p) {
        if (index[p] < 0) continue;
        b.segment<3>(3 * index[p]) += jac[p]->transpose() * omega * r;
        for (int q = 0; q < 2; ++q) {
          if (index[q] < 0) continue;
          h.block<3, 3>(3 * index[p], 3 * index[q]) += jac[p]->transpose() * omega * *jac[q];
        }
      }
    }
    const Eigen::VectorXd dx = h.ldlt().solve(-b);
    OptimizerOptions options;
    options.algorithm = Algorithm::kGaussNewton;
    options.max_iterations = 1;
    PoseGraph stepped = g;
    const OptimizerResult r = Optimizer(options).optimize(stepped);
    EXPECT_NEAR(r.initial_chi2, g.chi2(), 1e-12 * g.chi2());
    for (int k = 0; k < vars; ++k) {
      const Pose2& before = g.nodes()[k + 1].pose;
      const Pose2& after = stepped.nodes()[k + 1].pose;
      EXPECT_NEAR(after.x(), before.x() + dx[3 * k], 1e-8);
      EXPECT_NEAR(after.y(), before.y() + dx[3 * k + 1], 1e-8);
      EXPECT_NEAR(geometry::angleDiff(after.theta(), before.theta() + dx[3 * k + 2]), 0.0, 1e-8);
    }
  }
}

TEST(Optimizer, DisablingAnEdgeKeepsTheStructure) {
  testing::Synthetic s = testing::makeLaps(2, 5, 0.05, 0.02, 8);
  Optimizer optimizer;
  OptimizerResult r = optimizer.optimize(s.graph);
  EXPECT_TRUE(r.reanalysed);
  const std::size_t loop = s.graph.numEdges() - 3;
  ASSERT_EQ(s.graph.edges()[loop].kind, EdgeKind::kLoopClosure);
  s.graph.setEdgeEnabled(loop, false);
  r = optimizer.optimize(s.graph);
  EXPECT_FALSE(r.reanalysed);
  EXPECT_TRUE(r.converged);
  // Same optimum as a graph that never had the edge.
  PoseGraph without;
  for (const Node& n : s.graph.nodes()) without.addNode(n);
  for (std::size_t e = 0; e < s.graph.numEdges(); ++e) {
    if (e != loop) without.addEdge(s.graph.edges()[e]);
  }
  Optimizer().optimize(without);
  EXPECT_NEAR(without.chi2(), s.graph.chi2(), 1e-8 * without.chi2());
}

TEST(Optimizer, IncrementalAdditionsReanalyseOnlyWhenNeeded) {
  testing::Synthetic s = testing::makeLaps(2, 5, 0.05, 0.02, 9);
  Optimizer optimizer;
  EXPECT_TRUE(optimizer.optimize(s.graph).reanalysed);
  EXPECT_FALSE(optimizer.optimize(s.graph).reanalysed);
  const NodeId last = s.graph.nodes().back().id;
  const Pose2 step(1.0, 0.0, 0.0);
  s.graph.addNode(last + 1, s.graph.node(last).pose * step);
  s.graph.addEdge(last, last + 1, step, Eigen::Matrix3d::Identity() * 100.0);
  const OptimizerResult r = optimizer.optimize(s.graph);
  EXPECT_TRUE(r.reanalysed);
  EXPECT_TRUE(r.converged);
  // Starting from the previous optimum takes fewer steps than starting from odometry.
  PoseGraph fresh = s.graph;
  initializeFromOdometry(fresh);
  const OptimizerResult cold = Optimizer().optimize(fresh);
  EXPECT_LT(r.iterations, cold.iterations);
  EXPECT_NEAR(fresh.chi2(), s.graph.chi2(), 1e-6 * fresh.chi2());
}

TEST(Optimizer, GaugeRules) {
  PoseGraph g;
  for (int k = 0; k < 4; ++k) g.addNode(k, Pose2(k, 0.1 * k, 0));
  g.addEdge(0, 1, Pose2(1, 0, 0), Eigen::Matrix3d::Identity());
  g.addEdge(2, 3, Pose2(1, 0, 0), Eigen::Matrix3d::Identity());
  try {
    Optimizer().optimize(g);
    FAIL() << "a component without a fixed node was optimised";
  } catch (const GraphError& error) {
    EXPECT_NE(std::string(error.what()).find("node 2"), std::string::npos) << error.what();
  }
  OptimizerOptions options;
  options.gauge = GaugeMode::kPerComponent;
  const OptimizerResult r = Optimizer(options).optimize(g);
  EXPECT_EQ(r.components, 2);
  EXPECT_EQ(r.auto_fixed, (std::vector<NodeId>{0, 2}));
  EXPECT_LT(r.final_chi2, 1e-12);
  EXPECT_EQ(g.node(2).pose.x(), 2.0);  // the auto-fixed node did not move
  // A user-fixed node in each component needs no automatic gauge.
  g.setFixed(1, true);
  g.setFixed(3, true);
  EXPECT_TRUE(Optimizer().optimize(g).auto_fixed.empty());
}

TEST(Optimizer, MarginalCovariancesMatchTheDenseInverse) {
  testing::Synthetic s = testing::makeLaps(2, 4, 0.05, 0.02, 13);
  Optimizer optimizer;
  optimizer.optimize(s.graph);
  // Dense H from the edge Jacobians, node 0 fixed.
  const int n = static_cast<int>(s.graph.numNodes()) - 1;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (std::size_t e = 0; e < s.graph.numEdges(); ++e) {
    Eigen::Matrix3d ji, jj;
    const std::size_t a = s.graph.edgeFromIndex(e), b = s.graph.edgeToIndex(e);
    edgeResidual(s.graph.nodes()[a].pose, s.graph.nodes()[b].pose, s.graph.edges()[e].measurement,
                 &ji, &jj);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3, 3 * n);
    if (a > 0) j.middleCols<3>(3 * (a - 1)) = ji;
    if (b > 0) j.middleCols<3>(3 * (b - 1)) = jj;
    h += j.transpose() * s.graph.edges()[e].information * j;
  }
  const Eigen::MatrixXd cov = h.inverse();
  const std::vector<NodeId> ids{0, 1, 3, 8, 17, 31};
  const auto marginals = optimizer.marginalCovariances(s.graph, ids);
  ASSERT_EQ(marginals.size(), ids.size());
  EXPECT_EQ(marginals.at(0), Eigen::Matrix3d::Zero());
  for (NodeId id : {1, 3, 8, 17, 31}) {
    const Eigen::Matrix3d expected = cov.block<3, 3>(3 * (id - 1), 3 * (id - 1));
    EXPECT_LT((marginals.at(id) - expected).cwiseAbs().maxCoeff(),
              1e-9 * expected.cwiseAbs().maxCoeff())
        << "node " << id << "\n"
        << marginals.at(id) << "\nvs\n"
        << expected;
  }
  // Uncertainty grows along the first lap, away from the fixed node.
  EXPECT_GT(marginals.at(8).trace(), marginals.at(1).trace());
  EXPECT_THROW(optimizer.marginalCovariances(s.graph, {999}), GraphError);
}

TEST(RobustKernel, WeightIsTheDerivativeOfRho) {
  for (RobustKernelType type : {RobustKernelType::kHuber, RobustKernelType::kCauchy}) {
    const RobustKernel kernel{type, 1.5};
    for (double s : {0.1, 1.0, 2.0, 5.0, 40.0, 1000.0}) {
      double rho_p, rho_m, rho, w, unused;
      robustKernel(kernel, s + 1e-6, &rho_p, &unused);
      robustKernel(kernel, s - 1e-6, &rho_m, &unused);
      robustKernel(kernel, s, &rho, &w);
      EXPECT_NEAR(w, (rho_p - rho_m) / 2e-6, 1e-6) << robustKernelName(type) << " s=" << s;
      EXPECT_LE(rho, s + 1e-12);
    }
  }
  double rho, w;
  robustKernel({RobustKernelType::kDcs, 1.0}, 0.5, &rho, &w);
  EXPECT_EQ(w, 1.0);
  robustKernel({RobustKernelType::kDcs, 1.0}, 99.0, &rho, &w);
  EXPECT_NEAR(w, std::pow(2.0 / 100.0, 2), 1e-15);
}

// False loop closures among true ones: the robust objective keeps the true solution and
// names exactly the false edges.
TEST(Optimizer, RobustKernelRejectsFalseLoopClosures) {
  for (double fraction : {0.1, 0.3}) {
    testing::Synthetic s = testing::makeLaps(4, 6, 0.02, 0.005, 17);
    PoseGraph clean = s.graph;
    Optimizer().optimize(clean);
    std::mt19937_64 rng(99);
    std::uniform_int_distribution<int> node(0, static_cast<int>(s.graph.numNodes()) - 1);
    std::uniform_real_distribution<double> pos(-3, 3), ang(-M_PI, M_PI);
    int loops = 0;
    for (const Edge& e : s.graph.edges()) loops += e.kind == EdgeKind::kLoopClosure;
    const int outliers = static_cast<int>(std::round(fraction * loops));
    std::set<std::size_t> false_edges;
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    info(0, 0) = info(1, 1) = 1.0 / (0.02 * 0.02);
    info(2, 2) = 1.0 / (0.005 * 0.005);
    while (static_cast<int>(false_edges.size()) < outliers) {
      const int a = node(rng), b = node(rng);
      if (std::abs(a - b) < 2) continue;
      false_edges.insert(
          s.graph.addEdge(a, b, Pose2(pos(rng), pos(rng), ang(rng)), info, EdgeKind::kLoopClosure));
    }
    OptimizerOptions options;
    options.robust[static_cast<int>(EdgeKind::kLoopClosure)] = {RobustKernelType::kDcs, 10.0};
    const OptimizerResult r = Optimizer(options).optimize(s.graph);
    EXPECT_TRUE(r.converged) << r.termination;
    double angle = 0.0;
    EXPECT_LT(maxPoseDistance(s.graph, clean, &angle), 0.1) << "fraction " << fraction;
    EXPECT_LT(angle, M_PI / 180.0);
    const std::set<std::size_t> named(r.downweighted.begin(), r.downweighted.end());
    EXPECT_EQ(named, false_edges) << "fraction " << fraction;
    // Without the kernel the same graph is wrecked.
    PoseGraph plain = s.graph;
    for (std::size_t i = 0; i < plain.numNodes(); ++i) plain.setPoseAt(i, clean.nodes()[i].pose);
    Optimizer().optimize(plain);
    EXPECT_GT(maxPoseDistance(plain, clean, &angle), 0.1);
  }
}

TEST(OptimizerOptions, ReadStrictlyFromYaml) {
  const auto config = common::ConfigNode::loadString(
      "algorithm: gn\n"
      "linear_solver: eigen\n"
      "max_iterations: 7\n"
      "relative_chi2_tolerance: 1e-6\n"
      "gauge: per_component\n"
      "chord_pcg_iterations: 3\n"
      "chord_pcg_tolerance: 1e-4\n"
      "chord_pcg_min_cost: 3\n"
      "robust:\n"
      "  loop_closure: {kernel: cauchy, delta: 2.5}\n"
      "  inter_floor: {kernel: dcs}\n",
      "opt.yaml");
  const OptimizerOptions o = readOptimizerOptions(config);
  EXPECT_EQ(o.algorithm, Algorithm::kGaussNewton);
  EXPECT_EQ(o.linear_solver, "eigen");
  EXPECT_EQ(o.max_iterations, 7);
  EXPECT_EQ(o.relative_chi2_tolerance, 1e-6);
  EXPECT_EQ(o.gauge, GaugeMode::kPerComponent);
  EXPECT_EQ(o.chord_pcg_iterations, 3);
  EXPECT_EQ(o.chord_pcg_tolerance, 1e-4);
  EXPECT_EQ(o.chord_pcg_min_cost, 3.0);
  EXPECT_EQ(o.robust[static_cast<int>(EdgeKind::kLoopClosure)].type, RobustKernelType::kCauchy);
  EXPECT_EQ(o.robust[static_cast<int>(EdgeKind::kLoopClosure)].delta, 2.5);
  EXPECT_EQ(o.robust[static_cast<int>(EdgeKind::kInterFloor)].type, RobustKernelType::kDcs);
  EXPECT_EQ(o.robust[static_cast<int>(EdgeKind::kOdometry)].type, RobustKernelType::kNone);
  for (const char* bad :
       {"algorithm: newton\n", "max_iterations: 0\n", "tolerance: 1\n",
        "chord_pcg_iterations: -1\n", "chord_pcg_tolerance: 0\n",
        "robust:\n  loops: {kernel: dcs}\n", "robust:\n  odometry: {kernel: tukey}\n",
        "robust:\n  odometry: {kernel: dcs, width: 2}\n"}) {
    EXPECT_THROW(readOptimizerOptions(common::ConfigNode::loadString(bad, "opt.yaml")),
                 common::ConfigError)
        << bad;
  }
}

}  // namespace
}  // namespace storey::graph
