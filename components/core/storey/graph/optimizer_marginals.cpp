// Marginal covariances of chosen nodes from the optimiser's factorised system.
#include <algorithm>
#include <map>
#include <utility>
#include <vector>

#include "storey/graph/optimizer.h"
#include "storey/graph/optimizer_internal.h"

namespace storey::graph {

std::map<NodeId, Eigen::Matrix3d> Optimizer::marginalCovariances(const PoseGraph& graph,
                                                                 const std::vector<NodeId>& ids) {
  std::map<NodeId, Eigen::Matrix3d> out;
  for (NodeId id : ids) graph.nodeIndex(id);  // throws for unknown ids
  if (!structure_ || structure_->graph_version != graph.structureVersion()) {
    // Needs the structure of this graph: a zero-iteration optimisation builds it without
    // moving any pose.
    OptimizerOptions saved = options_;
    options_.max_iterations = 0;
    options_.initialization = Initialization::kNone;
    PoseGraph& mutable_graph = const_cast<PoseGraph&>(graph);
    optimize(mutable_graph);
    options_ = saved;
  }
  Structure& s = *structure_;
  const int n_vars = static_cast<int>(s.node_of_var.size());
  // Undamped H (with the robust weights) at the current poses.
  std::fill(s.h.values.begin(), s.h.values.end(), 0.0);
  Eigen::Matrix3d ji, jj;
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    const Edge& edge = graph.edges()[e];
    if (!edge.enabled) continue;
    const int vi = s.var_of_node[graph.edgeFromIndex(e)];
    const int vj = s.var_of_node[graph.edgeToIndex(e)];
    const Eigen::Vector3d r =
        edgeResidual(graph.nodes()[graph.edgeFromIndex(e)].pose,
                     graph.nodes()[graph.edgeToIndex(e)].pose, edge.measurement, &ji, &jj);
    double rho, w;
    robustKernel(options_.robust[static_cast<int>(edge.kind)], r.dot(edge.information * r), &rho,
                 &w);
    const Eigen::Matrix3d omega = w * edge.information;
    const Eigen::Matrix3d hii = ji.transpose() * omega * ji, hjj = jj.transpose() * omega * jj;
    for (int a = 0; a < 3; ++a) {
      for (int p = 0; p <= a; ++p) {
        if (vi >= 0) s.h.values[s.diag[vi][a] + p] += hii(p, a);
        if (vj >= 0) s.h.values[s.diag[vj][a] + p] += hjj(p, a);
      }
    }
    if (vi >= 0 && vj >= 0) {
      const Eigen::Matrix3d block = vi < vj ? Eigen::Matrix3d(ji.transpose() * omega * jj)
                                            : Eigen::Matrix3d(jj.transpose() * omega * ji);
      for (int a = 0; a < 3; ++a) {
        for (int p = 0; p < 3; ++p) s.h.values[s.offdiag[e][a] + p] += block(p, a);
      }
    }
  }
  std::vector<std::pair<NodeId, int>> wanted;
  for (NodeId id : ids) {
    const int v = s.var_of_node[graph.nodeIndex(id)];
    if (v < 0) {
      out[id] = Eigen::Matrix3d::Zero();
    } else {
      wanted.emplace_back(id, v);
    }
  }
  if (wanted.empty()) return out;
  if (!solver_->factorize(s.h)) {
    throw GraphError("marginal covariances: H is not positive definite at the current poses");
  }
  // Solve H X = E for the wanted nodes' unit columns, a bounded number at a time.
  constexpr std::size_t kChunk = 64;
  Eigen::MatrixXd e, x;
  for (std::size_t begin = 0; begin < wanted.size(); begin += kChunk) {
    const std::size_t end = std::min(wanted.size(), begin + kChunk);
    e.setZero(3 * n_vars, 3 * (end - begin));
    for (std::size_t k = begin; k < end; ++k) {
      for (int a = 0; a < 3; ++a) e(3 * wanted[k].second + a, 3 * (k - begin) + a) = 1.0;
    }
    solver_->solve(e, &x);
    for (std::size_t k = begin; k < end; ++k) {
      Eigen::Matrix3d cov = x.block<3, 3>(3 * wanted[k].second, 3 * (k - begin));
      out[wanted[k].first] = 0.5 * (cov + cov.transpose());
    }
  }
  return out;
}

}  // namespace storey::graph
