// A planar pose graph: SE(2) nodes (with the floor they lie on) joined by relative-pose
// edges. The graph only stores and validates; storey/graph/optimizer.h optimises it.
//
//   PoseGraph graph;
//   graph.addNode(0, Pose2(0, 0, 0), /*fixed=*/true);
//   graph.addNode(1, Pose2(1, 0, 0));
//   graph.addEdge(0, 1, Pose2(1, 0, 0), Eigen::Matrix3d::Identity(), EdgeKind::kOdometry);
//   Optimizer optimizer;                      // options: readOptimizerOptions(config)
//   OptimizerResult result = optimizer.optimize(graph);   // updates the node poses
//
// Every mutation that changes which nodes are variables or which pairs are joined
// bumps structureVersion(); the optimiser re-analyses the sparsity only then.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "storey/geometry/pose2.h"

namespace storey::graph {

using NodeId = std::int64_t;

// Where an edge came from; robust kernels are chosen per kind.
enum class EdgeKind { kOdometry = 0, kScanMatch = 1, kLoopClosure = 2, kInterFloor = 3 };
constexpr int kEdgeKindCount = 4;
const char* edgeKindName(EdgeKind kind);  // "odometry", "scan_match", ...
// Parses a name from edgeKindName(); throws std::invalid_argument for anything else.
EdgeKind parseEdgeKind(const std::string& name);

struct Node {
  NodeId id = 0;
  geometry::Pose2 pose;
  int floor = 0;        // floor id the pose lies on
  double height = 0.0;  // that floor's height tag (metres); not optimised here
  bool fixed = false;   // held constant by the optimiser (gauge)
};

// Measurement z of pose `to` in the frame of pose `from`: z ≈ x_from⁻¹ · x_to.
struct Edge {
  NodeId from = 0;
  NodeId to = 0;
  geometry::Pose2 measurement;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();  // of (x, y, theta)
  EdgeKind kind = EdgeKind::kOdometry;
  bool enabled = true;  // a disabled edge contributes nothing but keeps its place
};

// Thrown for invalid graph content; what() names the node or edge at fault.
class GraphError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Residual of one edge, e = toVector(z⁻¹ · (xi⁻¹ · xj)) = (x, y, θ) with θ wrapped, and its
// Jacobians with respect to xi and xj in the (x, y, θ) parametrisation (either may be null).
Eigen::Vector3d edgeResidual(const geometry::Pose2& xi, const geometry::Pose2& xj,
                             const geometry::Pose2& z, Eigen::Matrix3d* d_xi = nullptr,
                             Eigen::Matrix3d* d_xj = nullptr);

// Checks that an information matrix is finite, symmetric and positive definite; returns an
// empty string when it is, else the reason.
std::string informationProblem(const Eigen::Matrix3d& information);

class PoseGraph {
 public:
  PoseGraph();

  // Adds a node. Throws GraphError for a duplicate id or a non-finite pose/height.
  void addNode(const Node& node);
  void addNode(NodeId id, const geometry::Pose2& pose, bool fixed = false, int floor = 0,
               double height = 0.0);
  // Adds an edge and returns its index. Throws GraphError for an unknown node, a self-loop,
  // a non-finite measurement or an information matrix that is not positive definite.
  std::size_t addEdge(const Edge& edge);
  std::size_t addEdge(NodeId from, NodeId to, const geometry::Pose2& measurement,
                      const Eigen::Matrix3d& information, EdgeKind kind = EdgeKind::kOdometry);

  bool hasNode(NodeId id) const { return index_.count(id) != 0; }
  // Throws GraphError for an unknown id.
  std::size_t nodeIndex(NodeId id) const;
  const Node& node(NodeId id) const { return nodes_[nodeIndex(id)]; }
  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<Edge>& edges() const { return edges_; }
  std::size_t numNodes() const { return nodes_.size(); }
  std::size_t numEdges() const { return edges_.size(); }
  // Node indices (into nodes()) of edge e's endpoints.
  std::size_t edgeFromIndex(std::size_t e) const { return edge_index_[e].first; }
  std::size_t edgeToIndex(std::size_t e) const { return edge_index_[e].second; }

  void setPose(NodeId id, const geometry::Pose2& pose);
  void setPoseAt(std::size_t index, const geometry::Pose2& pose) { nodes_[index].pose = pose; }
  void setFixed(NodeId id, bool fixed);
  // Enabling/disabling keeps the structure: the optimiser zeroes the edge's contribution.
  void setEdgeEnabled(std::size_t edge, bool enabled);

  // Changes whenever nodes or edges are added or a fixed flag changes (not for poses or
  // enabled flags). Unique across graphs, so a cache keyed by it never mixes two graphs.
  std::uint64_t structureVersion() const { return version_; }

  // Connected components over enabled edges: the component of each node (by index), and
  // their count in *count.
  std::vector<int> connectedComponents(int* count) const;

  // Σ eᵀ Ω e over enabled edges (no robust kernel).
  double chi2() const;
  double edgeChi2(std::size_t e) const;

 private:
  void bumpVersion();

  std::vector<Node> nodes_;
  std::vector<Edge> edges_;
  std::vector<std::pair<std::size_t, std::size_t>> edge_index_;
  std::unordered_map<NodeId, std::size_t> index_;
  std::uint64_t version_ = 0;
};

// Sets the pose of every node reachable from the first node (lowest id) by composing edge
// measurements along a spanning tree that prefers odometry-kind edges, so a chain of
// consecutive odometry gives the dead-reckoning guess. Unreached nodes keep their poses;
// returns how many nodes were reached. The first node keeps its pose.
std::size_t initializeFromOdometry(PoseGraph& graph);

}  // namespace storey::graph
