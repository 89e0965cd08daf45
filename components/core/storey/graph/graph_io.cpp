#include "storey/graph/graph_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <vector>

#include "storey/common/file_checks.h"
#include "storey/common/log.h"

namespace storey::graph {

using common::str;
using geometry::Pose2;

GraphFileError::GraphFileError(const std::string& file, int line, const std::string& problem)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                         problem),
      file_(file),
      line_(line) {}

namespace {

struct VertexLine {
  int line;
  NodeId id;
  Pose2 pose;
};

struct EdgeLine {
  int line;
  Edge edge;
};

class LineParser {
 public:
  LineParser(const std::string& file, int line, std::vector<std::string> tokens)
      : file_(file), line_(line), tokens_(std::move(tokens)) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw GraphFileError(file_, line_, problem);
  }

  void expectCount(std::size_t count, const char* layout) const {
    if (tokens_.size() != count) {
      fail(str(tokens_[0], " needs ", count - 1, " fields (", layout, "), found ",
               tokens_.size() - 1));
    }
  }

  NodeId id(std::size_t i, const char* field) const {
    const std::string& t = tokens_[i];
    errno = 0;
    char* end = nullptr;
    const long long value = std::strtoll(t.c_str(), &end, 10);
    if (t.empty() || *end != '\0' || errno == ERANGE) {
      fail(str(field, ": '", t, "' is not an integer id"));
    }
    return static_cast<NodeId>(value);
  }

  double number(std::size_t i, const char* field) const {
    const std::string& t = tokens_[i];
    char* end = nullptr;
    const double value = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0') fail(str(field, ": '", t, "' is not a number"));
    if (!std::isfinite(value)) fail(str(field, ": '", t, "' is not finite"));
    return value;
  }

  const std::vector<std::string>& tokens() const { return tokens_; }

 private:
  const std::string& file_;
  int line_;
  std::vector<std::string> tokens_;
};

EdgeKind kindFor(NodeId from, NodeId to) {
  return to == from + 1 ? EdgeKind::kOdometry : EdgeKind::kLoopClosure;
}

}  // namespace

GraphFormat graphFormatForPath(const std::string& path) {
  auto endsWith = [&](const std::string& suffix) {
    return path.size() >= suffix.size() &&
           path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  return endsWith(".graph") || endsWith(".toro") ? GraphFormat::kToro : GraphFormat::kG2o;
}

PoseGraph parseGraph(const std::string& text, GraphFormat format, const std::string& name,
                     GraphReadInfo* info) {
  const bool g2o = format == GraphFormat::kG2o;
  const std::string vertex_tag = g2o ? "VERTEX_SE2" : "VERTEX2";
  const std::string edge_tag = g2o ? "EDGE_SE2" : "EDGE2";
  std::vector<VertexLine> vertices;
  std::vector<EdgeLine> edges;
  std::vector<std::pair<int, NodeId>> fixes;

  std::istringstream in(text);
  std::string raw;
  int line_number = 0;
  while (std::getline(in, raw)) {
    ++line_number;
    std::istringstream words(raw);
    std::vector<std::string> tokens;
    for (std::string w; words >> w;) tokens.push_back(w);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    LineParser p(name, line_number, tokens);
    const std::string& tag = tokens[0];
    if (tag == vertex_tag) {
      p.expectCount(5, "id x y theta");
      vertices.push_back({line_number, p.id(1, "id"),
                          Pose2(p.number(2, "x"), p.number(3, "y"), p.number(4, "theta"))});
    } else if (tag == edge_tag) {
      p.expectCount(12, g2o ? "from to dx dy dtheta I11 I12 I13 I22 I23 I33"
                            : "from to dx dy dtheta I11 I12 I22 I33 I13 I23");
      EdgeLine e{line_number, {}};
      e.edge.from = p.id(1, "from");
      e.edge.to = p.id(2, "to");
      e.edge.measurement = Pose2(p.number(3, "dx"), p.number(4, "dy"), p.number(5, "dtheta"));
      double v[6];
      static const char* const kG2oNames[6] = {"I11", "I12", "I13", "I22", "I23", "I33"};
      static const char* const kToroNames[6] = {"I11", "I12", "I22", "I33", "I13", "I23"};
      for (int k = 0; k < 6; ++k) v[k] = p.number(6 + k, g2o ? kG2oNames[k] : kToroNames[k]);
      double i11, i12, i13, i22, i23, i33;
      if (g2o) {
        i11 = v[0], i12 = v[1], i13 = v[2], i22 = v[3], i23 = v[4], i33 = v[5];
      } else {
        i11 = v[0], i12 = v[1], i22 = v[2], i33 = v[3], i13 = v[4], i23 = v[5];
      }
      e.edge.information << i11, i12, i13, i12, i22, i23, i13, i23, i33;
      e.edge.kind = kindFor(e.edge.from, e.edge.to);
      edges.push_back(e);
    } else if (g2o && tag == "FIX") {
      if (tokens.size() < 2) p.fail("FIX needs at least one vertex id");
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        fixes.emplace_back(line_number, p.id(k, "id"));
      }
    } else {
      p.fail(str("unknown or unsupported tag '", tag, "' (this reader takes ", vertex_tag, ", ",
                 edge_tag, g2o ? ", FIX" : "", ")"));
    }
  }

  PoseGraph graph;
  for (const VertexLine& v : vertices) {
    if (graph.hasNode(v.id)) throw GraphFileError(name, v.line, str("duplicate vertex id ", v.id));
    graph.addNode(v.id, v.pose);
  }
  const bool implicit = vertices.empty();
  if (implicit) {
    std::set<NodeId> ids;
    for (const EdgeLine& e : edges) {
      ids.insert(e.edge.from);
      ids.insert(e.edge.to);
    }
    for (NodeId id : ids) graph.addNode(id, Pose2());
  }
  for (const EdgeLine& e : edges) {
    try {
      graph.addEdge(e.edge);
    } catch (const GraphError& error) {
      throw GraphFileError(name, e.line, error.what());
    }
  }
  for (const auto& [line, id] : fixes) {
    if (!graph.hasNode(id)) throw GraphFileError(name, line, str("FIX of unknown vertex ", id));
    graph.setFixed(id, true);
  }
  if (implicit && !edges.empty()) initializeFromOdometry(graph);
  if (info) {
    info->format = format;
    info->vertices = vertices.size();
    info->edges = edges.size();
    info->initialized_from_odometry = implicit && !edges.empty();
  }
  return graph;
}

namespace {

// Larger g2o/TORO files than this are refused before reading (the whole text is held).
constexpr std::uint64_t kMaxGraphFileBytes = 1ull << 30;

std::string readText(const std::string& path) {
  try {
    common::requireRegularFile(path, "graph file", kMaxGraphFileBytes);
  } catch (const std::runtime_error& e) {
    throw GraphFileError(path, 0, std::string(e.what()).substr(path.size() + 2));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw GraphFileError(path, 0, "cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

PoseGraph readG2o(const std::string& path, GraphReadInfo* info) {
  return parseGraph(readText(path), GraphFormat::kG2o, path, info);
}

PoseGraph readToro(const std::string& path, GraphReadInfo* info) {
  return parseGraph(readText(path), GraphFormat::kToro, path, info);
}

PoseGraph readGraph(const std::string& path, GraphReadInfo* info) {
  return parseGraph(readText(path), graphFormatForPath(path), path, info);
}

std::string formatGraph(const PoseGraph& graph, GraphFormat format) {
  const bool g2o = format == GraphFormat::kG2o;
  std::ostringstream out;
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  for (const Node& n : graph.nodes()) {
    out << (g2o ? "VERTEX_SE2 " : "VERTEX2 ") << n.id << ' ' << n.pose.x() << ' ' << n.pose.y()
        << ' ' << n.pose.theta() << '\n';
  }
  if (g2o) {
    for (const Node& n : graph.nodes()) {
      if (n.fixed) out << "FIX " << n.id << '\n';
    }
  }
  for (const Edge& e : graph.edges()) {
    const Eigen::Matrix3d& m = e.information;
    out << (g2o ? "EDGE_SE2 " : "EDGE2 ") << e.from << ' ' << e.to << ' ' << e.measurement.x()
        << ' ' << e.measurement.y() << ' ' << e.measurement.theta() << ' ';
    if (g2o) {
      out << m(0, 0) << ' ' << m(0, 1) << ' ' << m(0, 2) << ' ' << m(1, 1) << ' ' << m(1, 2) << ' '
          << m(2, 2) << '\n';
    } else {
      out << m(0, 0) << ' ' << m(0, 1) << ' ' << m(1, 1) << ' ' << m(2, 2) << ' ' << m(0, 2) << ' '
          << m(1, 2) << '\n';
    }
  }
  return out.str();
}

namespace {

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("error while writing " + path);
}

}  // namespace

void writeG2o(const PoseGraph& graph, const std::string& path) {
  writeText(path, formatGraph(graph, GraphFormat::kG2o));
}

void writeToro(const PoseGraph& graph, const std::string& path) {
  writeText(path, formatGraph(graph, GraphFormat::kToro));
}

void writeGraph(const PoseGraph& graph, const std::string& path) {
  writeText(path, formatGraph(graph, graphFormatForPath(path)));
}

}  // namespace storey::graph
