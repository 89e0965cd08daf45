#include "storey/graph/pose_graph.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <deque>
#include <limits>
#include <sstream>

#include "storey/common/log.h"

namespace storey::graph {

using common::str;
using geometry::Pose2;

namespace {

// Versions are drawn from one counter so two graphs never share one.
std::uint64_t nextVersion() {
  static std::atomic<std::uint64_t> counter{1};
  return counter++;
}

}  // namespace

const char* edgeKindName(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry:
      return "odometry";
    case EdgeKind::kScanMatch:
      return "scan_match";
    case EdgeKind::kLoopClosure:
      return "loop_closure";
    case EdgeKind::kInterFloor:
      return "inter_floor";
  }
  return "unknown";
}

EdgeKind parseEdgeKind(const std::string& name) {
  for (int k = 0; k < kEdgeKindCount; ++k) {
    if (name == edgeKindName(static_cast<EdgeKind>(k))) return static_cast<EdgeKind>(k);
  }
  throw std::invalid_argument("unknown edge kind '" + name +
                              "' (odometry, scan_match, loop_closure, inter_floor)");
}

Eigen::Vector3d edgeResidual(const Pose2& xi, const Pose2& xj, const Pose2& z,
                             Eigen::Matrix3d* d_xi, Eigen::Matrix3d* d_xj) {
  // e_t = R(θi + θz)ᵀ (tj − ti) − R(θz)ᵀ tz, e_θ = θj − θi − θz (wrapped).
  const double phi = xi.theta() + z.theta();
  const double c = std::cos(phi), s = std::sin(phi);
  const double cz = std::cos(z.theta()), sz = std::sin(z.theta());
  const double dx = xj.x() - xi.x(), dy = xj.y() - xi.y();
  Eigen::Vector3d e;
  e.x() = c * dx + s * dy - (cz * z.x() + sz * z.y());
  e.y() = -s * dx + c * dy - (-sz * z.x() + cz * z.y());
  e.z() = geometry::normalizeAngle(xj.theta() - xi.theta() - z.theta());
  if (d_xi) {
    *d_xi << -c, -s, -s * dx + c * dy,  //
        s, -c, -c * dx - s * dy,        //
        0, 0, -1;
  }
  if (d_xj) {
    *d_xj << c, s, 0,  //
        -s, c, 0,      //
        0, 0, 1;
  }
  return e;
}

std::string informationProblem(const Eigen::Matrix3d& information) {
  if (!information.allFinite()) return "information matrix is not finite";
  const double scale = information.cwiseAbs().maxCoeff();
  if ((information - information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return "information matrix is not symmetric";
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(information, Eigen::EigenvaluesOnly);
  if (!(eig.eigenvalues().minCoeff() > 0.0)) {
    std::ostringstream out;
    out << "information matrix is not positive definite (eigenvalues "
        << eig.eigenvalues().transpose() << ")";
    return out.str();
  }
  return "";
}

PoseGraph::PoseGraph() : version_(nextVersion()) {}

void PoseGraph::bumpVersion() { version_ = nextVersion(); }

void PoseGraph::addNode(const Node& node) {
  if (index_.count(node.id)) throw GraphError(str("duplicate node id ", node.id));
  if (!node.pose.isFinite() || !std::isfinite(node.height)) {
    throw GraphError(str("node ", node.id, ": pose or height is not finite"));
  }
  index_.emplace(node.id, nodes_.size());
  nodes_.push_back(node);
  bumpVersion();
}

void PoseGraph::addNode(NodeId id, const Pose2& pose, bool fixed, int floor, double height) {
  Node node;
  node.id = id;
  node.pose = pose;
  node.fixed = fixed;
  node.floor = floor;
  node.height = height;
  addNode(node);
}

std::size_t PoseGraph::addEdge(const Edge& edge) {
  const std::string name = str("edge ", edge.from, " -> ", edge.to);
  auto from = index_.find(edge.from), to = index_.find(edge.to);
  if (from == index_.end()) throw GraphError(str(name, ": unknown node ", edge.from));
  if (to == index_.end()) throw GraphError(str(name, ": unknown node ", edge.to));
  if (edge.from == edge.to) throw GraphError(str(name, ": joins a node to itself"));
  if (!edge.measurement.isFinite()) throw GraphError(str(name, ": measurement is not finite"));
  const std::string problem = informationProblem(edge.information);
  if (!problem.empty()) throw GraphError(str(name, ": ", problem));
  edges_.push_back(edge);
  edge_index_.emplace_back(from->second, to->second);
  bumpVersion();
  return edges_.size() - 1;
}

std::size_t PoseGraph::addEdge(NodeId from, NodeId to, const Pose2& measurement,
                               const Eigen::Matrix3d& information, EdgeKind kind) {
  Edge edge;
  edge.from = from;
  edge.to = to;
  edge.measurement = measurement;
  edge.information = information;
  edge.kind = kind;
  return addEdge(edge);
}

std::size_t PoseGraph::nodeIndex(NodeId id) const {
  auto it = index_.find(id);
  if (it == index_.end()) throw GraphError(str("unknown node ", id));
  return it->second;
}

void PoseGraph::setPose(NodeId id, const Pose2& pose) {
  if (!pose.isFinite()) throw GraphError(str("node ", id, ": pose is not finite"));
  nodes_[nodeIndex(id)].pose = pose;
}

void PoseGraph::setFixed(NodeId id, bool fixed) {
  Node& node = nodes_[nodeIndex(id)];
  if (node.fixed != fixed) {
    node.fixed = fixed;
    bumpVersion();
  }
}

void PoseGraph::setEdgeEnabled(std::size_t edge, bool enabled) {
  if (edge >= edges_.size()) throw GraphError(str("edge index ", edge, " out of range"));
  edges_[edge].enabled = enabled;
}

std::vector<int> PoseGraph::connectedComponents(int* count) const {
  // Union-find over enabled edges, then components numbered in node order.
  std::vector<std::size_t> parent(nodes_.size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](std::size_t a) {
    while (parent[a] != a) {
      parent[a] = parent[parent[a]];
      a = parent[a];
    }
    return a;
  };
  for (std::size_t e = 0; e < edges_.size(); ++e) {
    if (!edges_[e].enabled) continue;
    const std::size_t a = find(edge_index_[e].first), b = find(edge_index_[e].second);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<int> component(nodes_.size(), -1);
  std::vector<int> label(nodes_.size(), -1);
  int n = 0;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const std::size_t root = find(i);
    if (label[root] < 0) label[root] = n++;
    component[i] = label[root];
  }
  if (count) *count = n;
  return component;
}

double PoseGraph::edgeChi2(std::size_t e) const {
  const Edge& edge = edges_[e];
  const Eigen::Vector3d r = edgeResidual(nodes_[edge_index_[e].first].pose,
                                         nodes_[edge_index_[e].second].pose, edge.measurement);
  return r.dot(edge.information * r);
}

double PoseGraph::chi2() const {
  double sum = 0.0;
  for (std::size_t e = 0; e < edges_.size(); ++e) {
    if (edges_[e].enabled) sum += edgeChi2(e);
  }
  return sum;
}

std::size_t initializeFromOdometry(PoseGraph& graph) {
  const std::size_t n = graph.numNodes();
  if (n == 0) return 0;
  // Adjacency over enabled edges; odometry edges first so the 0-1 BFS below follows
  // the odometry chain wherever it can.
  std::vector<std::vector<std::size_t>> incident(n);
  for (std::size_t e = 0; e < graph.numEdges(); ++e) {
    if (!graph.edges()[e].enabled) continue;
    incident[graph.edgeFromIndex(e)].push_back(e);
    incident[graph.edgeToIndex(e)].push_back(e);
  }
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return graph.nodes()[a].id < graph.nodes()[b].id;
  });
  const std::size_t kUnset = std::numeric_limits<std::size_t>::max();
  std::vector<int> cost(n, std::numeric_limits<int>::max());
  std::vector<std::size_t> via(n, kUnset);  // tree edge that reached the node
  std::vector<char> done(n, 0);
  std::size_t reached = 0;
  for (std::size_t root : order) {
    if (cost[root] != std::numeric_limits<int>::max()) continue;
    // 0-1 BFS: odometry edges cost 0, others 1; a node's pose is set when it is settled.
    std::deque<std::size_t> queue{root};
    cost[root] = 0;
    while (!queue.empty()) {
      const std::size_t u = queue.front();
      queue.pop_front();
      if (done[u]) continue;
      done[u] = 1;
      ++reached;
      if (via[u] != kUnset) {
        const Edge& edge = graph.edges()[via[u]];
        const bool forward = graph.edgeToIndex(via[u]) == u;
        const std::size_t parent =
            forward ? graph.edgeFromIndex(via[u]) : graph.edgeToIndex(via[u]);
        const Pose2& base = graph.nodes()[parent].pose;
        graph.setPoseAt(u, forward ? base * edge.measurement : base * edge.measurement.inverse());
      }
      for (std::size_t e : incident[u]) {
        const std::size_t v =
            graph.edgeFromIndex(e) == u ? graph.edgeToIndex(e) : graph.edgeFromIndex(e);
        if (done[v]) continue;
        const int w = graph.edges()[e].kind == EdgeKind::kOdometry ? 0 : 1;
        if (cost[u] + w < cost[v]) {
          cost[v] = cost[u] + w;
          via[v] = e;
          if (w == 0) {
            queue.push_front(v);
          } else {
            queue.push_back(v);
          }
        }
      }
    }
  }
  return reached;
}

}  // namespace storey::graph
