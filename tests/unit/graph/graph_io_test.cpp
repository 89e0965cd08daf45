#include "storey/graph/graph_io.h"

#include <gtest/gtest.h>

#include <fstream>
#include <utility>

#include "synthetic_graph.h"
#include "test_support.h"

namespace storey::graph {
namespace {

using geometry::Pose2;

void expectLineError(const std::string& text, GraphFormat format, int line,
                     const std::string& fragment) {
  try {
    parseGraph(text, format, "g.txt");
    FAIL() << "accepted: " << text;
  } catch (const GraphFileError& error) {
    EXPECT_EQ(error.line(), line) << error.what();
    EXPECT_EQ(error.file(), "g.txt");
    EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << error.what();
  }
}

TEST(GraphIo, ReadsG2oWithUpperTriangularInformationAndFix) {
  const std::string text =
      "# comment\n"
      "VERTEX_SE2 0 0 0 0\n"
      "VERTEX_SE2 1 1 0.5 0.1\n"
      "\n"
      "FIX 1\n"
      "EDGE_SE2 0 1 1 0 0.1 10 1 2 20 3 30\n"
      "EDGE_SE2 1 0 -1 0 0 1 0 0 1 0 1\n";
  GraphReadInfo info;
  PoseGraph g = parseGraph(text, GraphFormat::kG2o, "g.txt", &info);
  EXPECT_EQ(info.vertices, 2u);
  EXPECT_EQ(info.edges, 2u);
  EXPECT_FALSE(info.initialized_from_odometry);
  ASSERT_EQ(g.numNodes(), 2u);
  EXPECT_TRUE(g.node(1).fixed);
  EXPECT_FALSE(g.node(0).fixed);
  const Eigen::Matrix3d& m = g.edges()[0].information;
  EXPECT_EQ(m(0, 0), 10);
  EXPECT_EQ(m(0, 1), 1);
  EXPECT_EQ(m(1, 0), 1);
  EXPECT_EQ(m(0, 2), 2);
  EXPECT_EQ(m(1, 1), 20);
  EXPECT_EQ(m(1, 2), 3);
  EXPECT_EQ(m(2, 2), 30);
  EXPECT_EQ(g.edges()[0].kind, EdgeKind::kOdometry);
  EXPECT_EQ(g.edges()[1].kind, EdgeKind::kLoopClosure);
}

// A directory read as a graph would be an empty graph; a device never ends, a FIFO blocks.
// Refused by name before reading.
TEST(GraphIo, SpecialFilesAreRefusedByName) {
  for (const auto& [path, kind] :
       {std::pair<std::string, std::string>{test::makeTempDir("graph_dir"), "a directory"},
        {"/dev/zero", "a character device"}}) {
    try {
      readG2o(path);
      ADD_FAILURE() << path;
    } catch (const GraphFileError& e) {
      EXPECT_EQ(std::string(e.what()), path + ": " + kind + ", not a graph file");
    }
  }
}

TEST(GraphIo, ReadsToroInformationOrder) {
  // TORO: I11 I12 I22 I33 I13 I23.
  const std::string text = "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\n";
  PoseGraph g = parseGraph(text, GraphFormat::kToro, "g.graph");
  const Eigen::Matrix3d& m = g.edges()[0].information;
  EXPECT_EQ(m(0, 0), 10);
  EXPECT_EQ(m(0, 1), 1);
  EXPECT_EQ(m(1, 1), 20);
  EXPECT_EQ(m(2, 2), 30);
  EXPECT_EQ(m(0, 2), 2);
  EXPECT_EQ(m(2, 0), 2);
  EXPECT_EQ(m(1, 2), 3);
}

TEST(GraphIo, EdgesOnlyFilesGetAChainedOdometryGuess) {
  const std::string text =
      "EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\n"
      "EDGE_SE2 1 2 2 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 2 9 9 0 1 0 0 1 0 1\n";
  GraphReadInfo info;
  PoseGraph g = parseGraph(text, GraphFormat::kG2o, "g.txt", &info);
  EXPECT_TRUE(info.initialized_from_odometry);
  EXPECT_NEAR(g.node(2).pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(g.node(2).pose.y(), 2.0, 1e-12);
}

TEST(GraphIo, MalformedInputNamesFileAndLine) {
  const auto g2o = GraphFormat::kG2o;
  expectLineError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0\n", g2o, 2, "needs 4 fields");
  expectLineError("VERTEX_SE2 0 0 0 zero\n", g2o, 1, "theta");
  expectLineError("VERTEX_SE2 0 nan 0 0\n", g2o, 1, "not finite");
  expectLineError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n", g2o, 2, "duplicate vertex id 0");
  expectLineError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 5 1 0 0 1 0 0 1 0 1\n", g2o,
                  3, "unknown node 5");
  expectLineError("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 0 0 1\n", g2o,
                  3, "positive definite");
  expectLineError("VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 0 0\n", g2o, 2, "unknown or unsupported tag");
  expectLineError("VERTEX_SE2 0 0 0 0\nFIX 3\n", g2o, 2, "FIX of unknown vertex 3");
  expectLineError("VERTEX_SE2 0.5 0 0 0\n", g2o, 1, "integer id");
  expectLineError("VERTEX2 0 0 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0\n", GraphFormat::kToro, 2,
                  "needs 11 fields");
}

TEST(GraphIo, RoundTripsBothFormatsExactly) {
  testing::Synthetic s = testing::makeLaps(2, 4, 0.05, 0.01, 5);
  s.graph.setFixed(0, true);
  s.graph.setEdgeEnabled(0, true);
  const std::string dir = test::makeTempDir("graph_io");
  for (const char* name : {"/g.g2o", "/g.graph"}) {
    const std::string path = dir + name;
    writeGraph(s.graph, path);
    PoseGraph back = readGraph(path);
    ASSERT_EQ(back.numNodes(), s.graph.numNodes());
    ASSERT_EQ(back.numEdges(), s.graph.numEdges());
    for (std::size_t i = 0; i < back.numNodes(); ++i) {
      EXPECT_EQ(back.nodes()[i].id, s.graph.nodes()[i].id);
      EXPECT_EQ(back.nodes()[i].pose.x(), s.graph.nodes()[i].pose.x());
      EXPECT_EQ(back.nodes()[i].pose.theta(), s.graph.nodes()[i].pose.theta());
    }
    for (std::size_t e = 0; e < back.numEdges(); ++e) {
      EXPECT_EQ(back.edges()[e].information, s.graph.edges()[e].information);
      EXPECT_EQ(back.edges()[e].measurement.y(), s.graph.edges()[e].measurement.y());
    }
    EXPECT_EQ(back.node(0).fixed, std::string(name) == "/g.g2o");  // TORO has no FIX
    EXPECT_DOUBLE_EQ(back.chi2(), s.graph.chi2());
  }
  EXPECT_THROW(readGraph(dir + "/absent.g2o"), GraphFileError);
}

}  // namespace
}  // namespace storey::graph
