// What the optimiser's source files share: the assembled system of one graph structure.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "storey/graph/linear_solver.h"
#include "storey/graph/optimizer.h"

namespace storey::graph {

// The assembled system for one graph structure: which nodes are variables, the CSC pattern
// of H's upper triangle and where each edge and node writes into it.
struct Optimizer::Structure {
  std::uint64_t graph_version = 0;
  std::vector<char> fixed;  // effective fixed flag per node index (graph's + gauge's)
  std::vector<NodeId> auto_fixed;
  int components = 0;
  std::vector<int> var_of_node;  // -1 for fixed nodes
  std::vector<std::size_t> node_of_var;
  SparseUpper h;
  std::vector<std::array<int, 3>> diag;     // per variable: start of rows 3k.. in column 3k+a
  std::vector<std::array<int, 3>> offdiag;  // per edge: block start in column 3·max+a, or -1
  std::vector<int> diag_entry;              // position of H(i, i) per scalar variable
  std::vector<double> diag_saved;
  bool analysed = false;
};

}  // namespace storey::graph
