#include "storey/building/journal.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "test_support.h"

namespace storey::building {
namespace {

FloorGraphDelta makeDelta(int graph_id, int first_node, int count) {
  FloorGraphDelta d;
  d.robot = "robot_a";
  d.graph_id = graph_id;
  d.floor_id = graph_id;
  d.floor_height = 3.0 * graph_id;
  d.sequence = static_cast<std::uint32_t>(first_node);
  for (int i = first_node; i < first_node + count; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.stamp = 100.0 + i;
    n.pose = geometry::Pose2(i, 0.5 * i, 0.01 * i);
    n.odometry = geometry::Pose2(i + 0.1, 0.5 * i, 0.01 * i);
    n.scan.angle_min = -1.5;
    n.scan.angle_increment = 0.01;
    n.scan.range_min = 0.1;
    n.scan.range_max = 30;
    n.scan.ranges = {1.0f, std::numeric_limits<float>::quiet_NaN(), 3.0f};
    d.new_nodes.push_back(n);
    if (i > 0) {
      floor::FloorEdge e;
      e.from = i - 1;
      e.to = i;
      e.measurement = geometry::Pose2(1, 0.5, 0.01);
      e.information = Eigen::Vector3d(10, 20, 30).asDiagonal();
      e.kind = floor::EdgeKind::kScanMatch;
      d.new_edges.push_back(e);
    }
    d.poses[i] = n.pose;
  }
  return d;
}

TEST(Journal, RecordsRoundTrip) {
  const FloorGraphDelta delta = makeDelta(2, 0, 3);
  const auto decoded = std::get<FloorGraphDelta>(decodeRecord(encodeRecord(delta).data(), encodeRecord(delta).size()));
  EXPECT_EQ(decoded.robot, "robot_a");
  ASSERT_EQ(decoded.new_nodes.size(), 3u);
  EXPECT_EQ(decoded.new_nodes[2].scan.ranges.size(), 3u);
  EXPECT_TRUE(std::isnan(decoded.new_nodes[2].scan.ranges[1]));
  EXPECT_DOUBLE_EQ(decoded.new_nodes[2].odometry.x(), 2.1);
  EXPECT_EQ(decoded.new_edges.size(), 2u);
  EXPECT_EQ(decoded.new_edges[1].kind, floor::EdgeKind::kScanMatch);
  EXPECT_DOUBLE_EQ(decoded.new_edges[1].information(1, 1), 20.0);
  InterGraphConstraint c;
  c.id = 5;
  c.graph_from = 1;
  c.node_to = 7;
  c.dz = 3.25;
  const auto bytes = encodeRecord(c);
  const auto back = std::get<InterGraphConstraint>(decodeRecord(bytes.data(), bytes.size()));
  EXPECT_EQ(back.id, 5);
  EXPECT_EQ(back.node_to, 7);
  EXPECT_DOUBLE_EQ(back.dz, 3.25);
}

TEST(Journal, RestartRebuildsTheSameBuilding) {
  const std::string path = test::makeTempDir() + "/journal.bin";
  BuildingGraph original;
  {
    JournalWriter writer(path, true);
    EXPECT_TRUE(writer.existing().empty());
    for (int g : {0, 1}) {
      const auto delta = makeDelta(g, 0, 4);
      writer.append(delta);
      applyDelta(original, delta);
    }
    InterGraphConstraint c;
    c.id = 1;
    c.graph_from = 0;
    c.node_from = 1;
    c.graph_to = 1;
    c.node_to = 2;
    c.relative = geometry::Pose2(0.2, 0.1, 0.05);
    writer.append(c);
    original.addConstraint(c);
    const auto more = makeDelta(0, 4, 2);
    writer.append(more);
    applyDelta(original, more);
  }
  JournalWriter reopened(path, false);
  EXPECT_FALSE(reopened.hadTornTail());
  BuildingGraph rebuilt;
  for (const auto& record : reopened.existing()) applyRecord(rebuilt, record);
  ASSERT_EQ(rebuilt.floorGraphs().size(), 2u);
  EXPECT_EQ(rebuilt.floorGraphs().at(0).nodes.size(), 6u);
  EXPECT_EQ(rebuilt.floorGraphs().at(0).edges.size(), 5u);
  EXPECT_EQ(rebuilt.constraints().size(), 1u);
  const auto a = original.optimize(), b = rebuilt.optimize();
  EXPECT_DOUBLE_EQ(a.final_chi2, b.final_chi2);
  EXPECT_DOUBLE_EQ(a.placement(1)->transform.x(), b.placement(1)->transform.x());
}

TEST(Journal, RetractionsRoundTripAndARestartDoesNotBringTheConstraintBack) {
  ConstraintRetraction r;
  r.graph_from = 0;
  r.node_from = 1;
  r.graph_to = 1;
  r.node_to = 2;
  r.reason = "the new pass places node 2 of graph 1 3 m away";
  const auto bytes = encodeRecord(r);
  const auto back = std::get<ConstraintRetraction>(decodeRecord(bytes.data(), bytes.size()));
  EXPECT_EQ(back.graph_to, 1);
  EXPECT_EQ(back.node_to, 2);
  EXPECT_EQ(back.reason, r.reason);

  const std::string path = test::makeTempDir() + "/journal.bin";
  {
    JournalWriter writer(path, true);
    for (int g : {0, 1}) writer.append(makeDelta(g, 0, 4));
    InterGraphConstraint wrong, kept;
    wrong.graph_from = kept.graph_from = 0;
    wrong.graph_to = kept.graph_to = 1;
    wrong.node_from = 1;
    wrong.node_to = 2;
    kept.node_from = 3;
    kept.node_to = 3;
    writer.append(wrong);
    writer.append(kept);
    writer.append(r);
  }
  const JournalBuilding rebuilt = rebuildFromJournal(path);
  EXPECT_TRUE(rebuilt.skipped.empty());
  ASSERT_EQ(rebuilt.graph.constraints().size(), 1u);
  EXPECT_EQ(rebuilt.graph.constraints()[0].node_from, 3);
  // A retraction of a constraint the graph does not hold changes nothing.
  BuildingGraph copy = rebuilt.graph;
  EXPECT_EQ(copy.retractConstraint(r), 0u);
  EXPECT_EQ(copy.constraints().size(), 1u);
}

TEST(Journal, TornTailIsDroppedAndAppendingContinues) {
  const std::string path = test::makeTempDir() + "/journal.bin";
  {
    JournalWriter writer(path, false);
    writer.append(makeDelta(0, 0, 2));
    writer.append(makeDelta(0, 2, 2));
  }
  const auto full = std::filesystem::file_size(path);
  ASSERT_EQ(truncate(path.c_str(), static_cast<off_t>(full - 7)), 0);  // crash mid-write
  const JournalReadResult read = readJournal(path);
  EXPECT_TRUE(read.torn_tail);
  EXPECT_EQ(read.records.size(), 1u);
  {
    JournalWriter writer(path, false);
    EXPECT_TRUE(writer.hadTornTail());
    EXPECT_EQ(writer.existing().size(), 1u);
    writer.append(makeDelta(0, 2, 2));
  }
  const JournalReadResult again = readJournal(path);
  EXPECT_FALSE(again.torn_tail);
  EXPECT_EQ(again.records.size(), 2u);
}

TEST(Journal, CorruptionBeforeTheEndIsAnErrorNamingTheOffset) {
  const std::string path = test::makeTempDir() + "/journal.bin";
  {
    JournalWriter writer(path, false);
    writer.append(makeDelta(0, 0, 2));
    writer.append(makeDelta(0, 2, 2));
  }
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('\x7f');
  }
  try {
    readJournal(path);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("offset 8"), std::string::npos) << e.what();
  }
  std::ofstream(path + ".other") << "hello world, not a journal";
  EXPECT_THROW(readJournal(path + ".other"), std::runtime_error);
}

TEST(Journal, DeltaWithUnknownNodeIsRejected) {
  BuildingGraph building;
  FloorGraphDelta d = makeDelta(0, 0, 2);
  d.new_edges.push_back({0, 42, geometry::Pose2(), Eigen::Matrix3d::Identity(), floor::EdgeKind::kOdometry});
  EXPECT_THROW(applyDelta(building, d), std::invalid_argument);
  // Re-sending the same update does not duplicate anything.
  const FloorGraphDelta ok = makeDelta(0, 0, 3);
  applyDelta(building, ok);
  applyDelta(building, ok);
  EXPECT_EQ(building.floorGraphs().at(0).nodes.size(), 3u);
  EXPECT_EQ(building.floorGraphs().at(0).edges.size(), 2u);
}

// Values with no meaning in a floor graph are refused whole, naming the graph: a floor
// height of 1e300 m (far beyond any OctoMap), non-finite poses and edges.
TEST(Journal, DeltasWithValuesOutOfReachAreRejected) {
  auto errorOf = [](const FloorGraphDelta& d) {
    BuildingGraph building;
    try {
      applyDelta(building, d);
    } catch (const std::invalid_argument& e) {
      EXPECT_TRUE(building.floorGraphs().empty());
      return std::string(e.what());
    }
    return std::string();
  };
  FloorGraphDelta high = makeDelta(0, 0, 2);
  high.floor_height = 1e300;
  EXPECT_NE(errorOf(high).find("floor graph 0 (robot robot_a): floor height 1e+300 m"),
            std::string::npos)
      << errorOf(high);
  FloorGraphDelta nan_pose = makeDelta(0, 0, 2);
  nan_pose.new_nodes[1].pose = geometry::Pose2(std::nan(""), 0, 0);
  EXPECT_NE(errorOf(nan_pose).find("node 1 has a non-finite pose"), std::string::npos)
      << errorOf(nan_pose);
  FloorGraphDelta nan_edge = makeDelta(0, 0, 2);
  nan_edge.new_edges[0].measurement =
      geometry::Pose2(0, std::numeric_limits<double>::infinity(), 0);
  EXPECT_NE(errorOf(nan_edge).find("edge 0 -> 1 has non-finite values"), std::string::npos)
      << errorOf(nan_edge);
  EXPECT_EQ(errorOf(makeDelta(0, 0, 2)), "");
}

// Two robots' mappers that used the same floor-graph id would have their graphs merged
// (nodes of one dropped as already present): the second is rejected, naming both robots.
TEST(Journal, AnotherRobotsDeltaUnderTheSameGraphIdIsRejected) {
  BuildingGraph building;
  applyDelta(building, makeDelta(0, 0, 3));
  FloorGraphDelta other = makeDelta(0, 0, 3);
  other.robot = "robot_b";
  try {
    applyDelta(building, other);
    FAIL() << "robot_b's delta merged into robot_a's graph";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("robot_a"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("robot_b"), std::string::npos) << e.what();
  }
  EXPECT_EQ(building.floorGraphs().at(0).robot, "robot_a");
  EXPECT_EQ(building.floorGraphs().at(0).nodes.size(), 3u);
  // Under its own id it is taken.
  other.graph_id = 1000;
  applyDelta(building, other);
  EXPECT_EQ(building.floorGraphs().size(), 2u);
}

TEST(Journal, RebuildSkipsARecordItCannotApplyNamingItAndKeepsTheRest) {
  const std::string path = test::makeTempDir() + "/journal.bin";
  {
    JournalWriter writer(path, false);
    writer.append(makeDelta(0, 0, 3));
    InterGraphConstraint to_nowhere;  // graph 5 was never journalled
    to_nowhere.graph_from = 0;
    to_nowhere.graph_to = 5;
    writer.append(to_nowhere);
    writer.append(makeDelta(1, 0, 2));
    writer.append(makeDelta(0, 3, 2));
  }
  const JournalBuilding rebuilt = rebuildFromJournal(path);
  EXPECT_EQ(rebuilt.records, 4u);
  EXPECT_FALSE(rebuilt.torn_tail);
  ASSERT_EQ(rebuilt.skipped.size(), 1u);
  EXPECT_EQ(rebuilt.skipped[0].rfind("record 2: ", 0), 0u) << rebuilt.skipped[0];
  ASSERT_EQ(rebuilt.graph.floorGraphs().size(), 2u);
  EXPECT_EQ(rebuilt.graph.floorGraphs().at(0).nodes.size(), 5u);
  EXPECT_EQ(rebuilt.graph.floorGraphs().at(1).nodes.size(), 2u);
  EXPECT_TRUE(rebuilt.graph.constraints().empty());
}

}  // namespace
}  // namespace storey::building
