// Orientation-first initialisation of a planar pose graph (the linear approximation of
// Carlone et al., "LAGO", 2014): estimate all orientations first from the edges' relative
// rotations — a linear least-squares problem once each edge's 2π ambiguity is fixed from a
// breadth-first spanning tree — then all positions with those orientations held, another
// linear problem. Two sparse Cholesky solves; on intel, manhattan, city10000 and MIT the
// result is close enough to the optimum that Gauss-Newton converges in a few steps, where
// chained odometry or a poor file guess needs many (MIT: LM does not converge in 100).
// False loop closures corrupt it like any least-squares estimate: robust runs should start
// from odometry instead.
#pragma once

#include <cstddef>
#include <vector>

#include "storey/graph/pose_graph.h"

namespace storey::graph {

struct OrientationFirstInfo {
  std::size_t nodes = 0;          // nodes moved (free ones)
  std::size_t wrapped_edges = 0;  // edges whose rotation needed a 2π·k correction
  double seconds = 0.0;
  std::vector<char> anchored;  // per node index: held as an anchor
  // Fill-reducing order (AMD, new → old) of the free nodes numbered in node order over the
  // enabled edges: the optimiser reuses it for its own system on the same pattern.
  std::vector<int> ordering;
};

// Moves every free node. Anchors (kept as they are): the fixed nodes and, in each connected
// component (over enabled edges) without one, its first node — the optimiser's gauge rules.
// Disabled edges are ignored. Weights come from each edge's covariance Ω⁻¹ (its θθ entry for
// the orientations, its xy block for the positions).
OrientationFirstInfo initializeOrientationFirst(PoseGraph& graph);

}  // namespace storey::graph
