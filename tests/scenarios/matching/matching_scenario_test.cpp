// The floor matcher on simulated buildings (every scenario, two seeds) and on real logs:
// never a wrong constraint; at least three for every floor that shares structure with
// another; none for two different buildings; a symmetric floor only through sequences
// that tell it from its twin.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <sstream>

#include "storey/eval/log_floors.h"
#include "storey/eval/simulated_floors.h"
#include "storey/io/carmen.h"
#include "storey/matching/floor_matcher.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "test_support.h"

namespace storey::matching {
namespace {

// The test beds (simulated and log floor graphs, judged against their truth).
using eval::alignmentError;
using eval::ConstraintError;
using eval::floorGraphFromLasers;
using eval::floorGraphsFromSimulation;
using eval::LogFloorOptions;
using eval::SimulatedFloors;
using eval::SimulatedFloorsOptions;

FloorMatcherOptions shippedOptions() {
  const auto root = common::ConfigNode::loadFile(test::sourceDir() + "/config/floor_matcher.yaml");
  return readFloorMatcherOptions(root.child("floor_matcher"));
}

struct Expectation {
  std::string scenario;
  bool every_floor = true;  // every floor graph must get >= 3 constraints
};

class SimulatedScenario : public ::testing::TestWithParam<std::tuple<Expectation, int>> {};

TEST_P(SimulatedScenario, NoWrongConstraintAndEnoughRightOnes) {
  const auto& [expect, seed] = GetParam();
  const std::string path = test::sourceDir() + "/config/buildings/" + expect.scenario + ".yaml";
  if (!std::filesystem::exists(path))
    GTEST_SKIP() << "scenario " << path << " is not in the tree yet";
  const sim::Simulation run =
      sim::simulate(sim::loadScenario(path), static_cast<std::uint64_t>(seed));
  SimulatedFloorsOptions so;
  so.seed = static_cast<std::uint64_t>(seed);
  const SimulatedFloors floors = floorGraphsFromSimulation(run, so);
  ASSERT_GE(floors.graphs.size(), 2u) << expect.scenario << " gives fewer than two floor graphs";
  FloorMatcherOptions options = shippedOptions();
  options.seed = static_cast<std::uint64_t>(seed);
  const MatchResult result = matchFloors(floors.graphs, options);
  std::ostringstream report;
  printMatchReport(report, result);
  std::cout << expect.scenario << " seed " << seed << ": " << result.constraints.size()
            << " constraints, " << result.seconds << " s\n";
  for (const auto& c : result.constraints) {
    const ConstraintJudgement e = judgeConstraint(c, floors);
    EXPECT_FALSE(e.wrong) << "wrong constraint graph " << c.graph_id << " node " << c.node_id
                          << ": " << e.along_weak << " m along its weak direction (claimed sigma "
                          << e.weak_sigma << " m), " << e.across_weak << " m across, "
                          << e.rotation * 180.0 / M_PI << " deg\n"
                          << report.str();
  }
  if (expect.every_floor) {
    for (const auto& g : floors.graphs) {
      if (g.graph_id == result.reference_graph_id) continue;
      int count = 0;
      for (const auto& c : result.constraints) count += c.graph_id == g.graph_id;
      EXPECT_GE(count, 3) << "graph " << g.graph_id << " (" << g.robot << ", floor " << g.floor_id
                          << ", " << g.nodes.size() << " nodes)\n"
                          << report.str();
    }
  }
}

std::string scenarioSeedName(const ::testing::TestParamInfo<std::tuple<Expectation, int>>& info) {
  return std::get<0>(info.param).scenario + "_seed" + std::to_string(std::get<1>(info.param));
}

// symmetric's floors are self-similar; with match_self_similar they are
// matched through the sequences that tell them from their 180° twin (those at the
// elevator door), so they may get constraints, but never a wrong one.
// glass3's floors share only the elevator core and a 2 m x 4 m corridor: its floors get
// their constraints only from the pairs that needed more evidence (time-reversed
// sequences, the wall recheck, and the evidence of two graphs combined through the one
// already aligned; docs/floor_matcher.md).
INSTANTIATE_TEST_SUITE_P(
    Buildings, SimulatedScenario,
    ::testing::Combine(::testing::Values(Expectation{"small2"}, Expectation{"office4"},
                                         Expectation{"corridors3"}, Expectation{"glass3"},
                                         Expectation{"tower10"}, Expectation{"featureless"},
                                         Expectation{"symmetric", false},
                                         Expectation{"fleet"}),
                       ::testing::Values(1, 2)),
    scenarioSeedName);

// glass3 seeds 3 and 4 as well: on seed 4 each pass of F2 past the shared corridor gave a
// forward and a time-reversed sequence that share one end scan; counted as one piece of
// evidence, F2 would have 2 of the 3 it needs and get no constraint.
INSTANTIATE_TEST_SUITE_P(
    Glass3MoreSeeds, SimulatedScenario,
    ::testing::Combine(::testing::Values(Expectation{"glass3"}), ::testing::Values(3, 4)),
    scenarioSeedName);

// symmetric_room: the symmetric floors with one room of their own. No wrong constraint is
// all that is required. On seed 4 neither floor is self-similar and the pair is matched,
// so the pair's own rival-set test is what keeps the 180° twin out (16 right constraints);
// on seed 1 both floors are self-similar and are matched through their sequences that
// refute the twin (docs/floor_matcher.md).
INSTANTIATE_TEST_SUITE_P(
    SymmetricRoom, SimulatedScenario,
    ::testing::Combine(::testing::Values(Expectation{"symmetric_room", false}), ::testing::Values(1, 4)),
    scenarioSeedName);

// Two halves of one corrected log that cover the same rooms; the second is moved by a known
// offset and height and gets fresh odometry noise.
TEST(RealLogs, FreiburgHalvesRecoverTheKnownOffset) {
  STOREY_REQUIRE_DATA(path, "carmen/freiburg-079-corrected.log.gz");
  const auto lasers = io::readCarmenLasers(path);
  const geometry::Pose2 offset(3.0, -2.0, 25.0 * M_PI / 180.0);
  LogFloorOptions a, b;
  a.last = lasers.size() / 2;
  a.seed = 11;
  b.first = lasers.size() / 2;
  b.graph_id = b.floor_id = 1;
  b.floor_height = 3.0;
  b.frame = offset;
  b.seed = 12;
  SimulatedFloors floors;
  floors.graphs = {floorGraphFromLasers(lasers, a), floorGraphFromLasers(lasers, b)};
  floors.frames = {geometry::Pose2(), offset};
  const MatchResult result = matchFloors(floors.graphs, shippedOptions());
  std::ostringstream report;
  printMatchReport(report, result);
  ASSERT_GE(result.constraints.size(), 3u) << report.str();
  for (const auto& c : result.constraints) {
    EXPECT_FALSE(judgeConstraint(c, floors).wrong) << report.str();
    EXPECT_DOUBLE_EQ(std::abs(c.dz), 3.0);
  }
  const PairResult* pair = result.pairFor(result.reference_graph_id == 0 ? 1 : 0);
  ASSERT_TRUE(pair && pair->accepted);
  const ConstraintError e =
      alignmentError(pair->alignment, pair->reference_graph_id, pair->graph_id, floors);
  std::cout << "freiburg-079 halves: alignment error " << e.translation << " m, "
            << e.rotation * 180.0 / M_PI << " deg from " << result.constraints.size()
            << " constraints in " << result.seconds << " s\n";
  EXPECT_LT(e.translation, 0.05);
  EXPECT_LT(e.rotation, 0.2 * M_PI / 180.0);
}

TEST(RealLogs, IntelAgainstFreiburgGivesNoConstraint) {
  STOREY_REQUIRE_DATA(intel, "carmen/intel-corrected.log.gz");
  STOREY_REQUIRE_DATA(freiburg, "carmen/freiburg-079-corrected.log.gz");
  LogFloorOptions a, b;
  a.seed = 21;
  b.graph_id = b.floor_id = 1;
  b.floor_height = 3.0;
  b.seed = 22;
  std::vector<floor::FloorGraph> graphs{floorGraphFromLasers(io::readCarmenLasers(intel), a),
                                        floorGraphFromLasers(io::readCarmenLasers(freiburg), b)};
  const MatchResult result = matchFloors(graphs, shippedOptions());
  std::ostringstream report;
  printMatchReport(report, result);
  EXPECT_TRUE(result.constraints.empty()) << report.str();
}

}  // namespace
}  // namespace storey::matching
