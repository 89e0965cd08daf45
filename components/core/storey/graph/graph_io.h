// Pose-graph files: g2o (VERTEX_SE2, EDGE_SE2 with the upper triangle of the information
// matrix I11 I12 I13 I22 I23 I33, FIX) and TORO (VERTEX2, EDGE2 with the information in
// TORO's order I11 I12 I22 I33 I13 I23). '#' starts a comment line.
//
// A file with edges but no vertices gets one node per id met in the edges (ids ascending)
// and a chained-odometry initial guess (initializeFromOdometry). Edge kinds are not part of
// either format: an edge i → i+1 is read as odometry, any other as a loop closure.
// Malformed lines, unknown tags, duplicate vertex ids, edges to unknown vertices,
// non-finite numbers and information matrices that are not positive definite throw
// GraphFileError naming the file and line.
#pragma once

#include <stdexcept>
#include <string>

#include "storey/graph/pose_graph.h"

namespace storey::graph {

class GraphFileError : public std::runtime_error {
 public:
  GraphFileError(const std::string& file, int line, const std::string& problem);
  const std::string& file() const { return file_; }
  int line() const { return line_; }

 private:
  std::string file_;
  int line_;
};

enum class GraphFormat { kG2o, kToro };

struct GraphReadInfo {
  GraphFormat format = GraphFormat::kG2o;
  std::size_t vertices = 0;  // vertex lines read
  std::size_t edges = 0;
  bool initialized_from_odometry = false;  // the file had no vertices
};

// Format from the extension: ".graph" / ".toro" → TORO, anything else → g2o.
GraphFormat graphFormatForPath(const std::string& path);

// Reads a file in the format of its extension (graphFormatForPath).
PoseGraph readGraph(const std::string& path, GraphReadInfo* info = nullptr);
PoseGraph readG2o(const std::string& path, GraphReadInfo* info = nullptr);
PoseGraph readToro(const std::string& path, GraphReadInfo* info = nullptr);
// Parses text already in memory; `name` is used in error messages.
PoseGraph parseGraph(const std::string& text, GraphFormat format, const std::string& name,
                     GraphReadInfo* info = nullptr);

// Writes all nodes, FIX lines (g2o only) and enabled and disabled edges, in full precision.
// Throws std::runtime_error when the file cannot be written.
void writeGraph(const PoseGraph& graph, const std::string& path);  // format by extension
void writeG2o(const PoseGraph& graph, const std::string& path);
void writeToro(const PoseGraph& graph, const std::string& path);
std::string formatGraph(const PoseGraph& graph, GraphFormat format);

}  // namespace storey::graph
