// `storey experiments`: the table of one tower10 seed must agree with a direct evaluation
// of the run's outputs; the constraint check and the odometry baseline on small graphs.
#include "storey/tools/experiments.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

#include "storey/building/building_graph.h"
#include "storey/eval/corridors.h"
#include "storey/graph/graph_io.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;
using geometry::Pose2;

floor::FloorGraph lineGraph(int id, const std::string& robot, int floor_id, double start_stamp,
                            const std::vector<Pose2>& poses) {
  floor::FloorGraph g;
  g.robot = robot;
  g.graph_id = id;
  g.floor_id = floor_id;
  g.floor_height = 3.0 * floor_id;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    floor::FloorNode n;
    n.id = static_cast<int>(i);
    n.stamp = start_stamp + static_cast<double>(i);
    n.pose = poses[i];
    n.odometry = poses[i];
    g.nodes.push_back(n);
    if (i > 0) g.edges.push_back({static_cast<int>(i - 1), static_cast<int>(i), poses[i - 1].inverse() * poses[i]});
  }
  return g;
}

TEST(Experiments, SummaryStatistics) {
  const Statistic s = summarise({1.0, 2.0, 3.0, 6.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
  EXPECT_NEAR(s.std, std::sqrt(14.0 / 3.0), 1e-12);
  EXPECT_DOUBLE_EQ(s.worst, 6.0);
  EXPECT_DOUBLE_EQ(summarise({2.5}).std, 0.0);
  EXPECT_EQ(summarise({}).count, 0u);
}

TEST(Experiments, ConstraintsAreCheckedAgainstTruth) {
  // Two floors whose graphs are in frames unrelated to the truth: a constraint is right
  // when it relates the two nodes as their true poses do.
  const Pose2 a0(0, 0, 0), a1(1, 0, 0), b0(0.5, 0.2, 0.3);
  building::BuildingGraph graph;
  graph.upsertFloorGraph(lineGraph(1, "r", 0, 0.0, {Pose2(5, 5, 1), Pose2(5, 6, 1)}));
  graph.upsertFloorGraph(lineGraph(2, "r", 1, 10.0, {Pose2(-3, 2, 2), Pose2(-3, 3, 2)}));
  std::vector<eval::PoseRow> truth;
  for (auto [stamp, floor, pose] : std::vector<std::tuple<double, std::string, Pose2>>{
           {0.0, "F0", a0}, {1.0, "F0", a1}, {10.0, "F1", b0}})
    truth.push_back({stamp, "r", floor, pose, 0.0});
  building::InterGraphConstraint right;
  right.id = 1;
  right.graph_from = 1;
  right.node_from = 1;
  right.graph_to = 2;
  right.node_to = 0;
  right.relative = a1.inverse() * b0;
  right.information.diagonal() << 400.0, 400.0, 1e4;  // 0.05 m, 0.01 rad
  building::InterGraphConstraint wrong = right;
  wrong.id = 2;
  wrong.relative = right.relative * Pose2(0.5, 0.0, 0.0);
  building::InterGraphConstraint turned = right;
  turned.id = 3;
  turned.relative = right.relative * Pose2(0.0, 0.0, 0.05);
  building::InterGraphConstraint unknown = right;
  unknown.id = 4;
  unknown.node_to = 1;  // no true pose at its stamp
  // A corridor's constraint: it claims sigma 0.5 m along x of node_from's frame, and is
  // 0.5 m off along it (not wrong) or across it (wrong).
  building::InterGraphConstraint along = right;
  along.id = 5;
  along.information.setZero();
  along.information.diagonal() << 4.0, 400.0, 1e4;
  along.relative = Pose2(0.5, 0.0, 0.0) * right.relative;
  building::InterGraphConstraint across = along;
  across.id = 6;
  across.relative = Pose2(0.0, 0.5, 0.0) * right.relative;
  for (const auto& c : {right, wrong, turned, unknown, along, across}) graph.addConstraint(c);

  const auto checks = checkConstraints(graph, truth, ExperimentGoals{});
  ASSERT_EQ(checks.size(), 6u);
  EXPECT_TRUE(checks[0].checked);
  EXPECT_EQ(checks[0].floor_from, "F0");
  EXPECT_EQ(checks[0].floor_to, "F1");
  EXPECT_NEAR(checks[0].judgement.translation, 0.0, 1e-9);
  EXPECT_FALSE(checks[0].judgement.wrong);
  EXPECT_NEAR(checks[1].judgement.translation, 0.5, 1e-9);
  EXPECT_TRUE(checks[1].judgement.wrong);
  EXPECT_NEAR(checks[2].judgement.rotation, 0.05, 1e-9);
  EXPECT_TRUE(checks[2].judgement.wrong);  // 2.9 degrees
  EXPECT_FALSE(checks[3].checked);
  EXPECT_FALSE(checks[3].judgement.wrong);
  EXPECT_NEAR(checks[4].judgement.translation, 0.5, 1e-9);
  EXPECT_NEAR(checks[4].judgement.along_weak, 0.5, 1e-9);
  EXPECT_NEAR(checks[4].judgement.weak_sigma, 0.5, 1e-9);
  EXPECT_TRUE(checks[4].judgement.off);
  EXPECT_FALSE(checks[4].judgement.wrong);
  EXPECT_NEAR(checks[5].judgement.along_weak, 0.0, 1e-9);
  EXPECT_TRUE(checks[5].judgement.wrong);
}

TEST(Experiments, OdometryChainPlacesTheNextFloorWhereOdometrySays) {
  building::BuildingGraph graph;
  graph.upsertFloorGraph(lineGraph(1, "r", 0, 0.0, {Pose2(0, 0, 0), Pose2(1, 0, 0)}));
  graph.upsertFloorGraph(lineGraph(2, "r", 1, 10.0, {Pose2(0, 0, 0), Pose2(0, 1, M_PI / 2)}));
  // Odometry: at stamp 1 the robot is at (1, 0, 0); at stamp 10 it has turned around in
  // the elevator at (3, 0).
  std::map<std::string, std::vector<sensor::OdometrySample>> odometry;
  for (auto [stamp, pose] : std::vector<std::pair<double, Pose2>>{
           {0.0, Pose2(0, 0, 0)}, {1.0, Pose2(1, 0, 0)}, {5.0, Pose2(3, 0, 0)}, {10.0, Pose2(3, 0, M_PI)}}) {
    sensor::OdometrySample s;
    s.stamp = stamp;
    s.pose = pose;
    odometry["r"].push_back(s);
  }
  const auto solution = solveWithOdometryChain(graph, odometry);
  const Pose2 first = solution.poses.at({1, 1});
  const Pose2 second = solution.poses.at({2, 0});
  const Pose2 relative = first.inverse() * second;
  EXPECT_NEAR(relative.x(), 2.0, 1e-6);
  EXPECT_NEAR(relative.y(), 0.0, 1e-6);
  EXPECT_NEAR(std::abs(relative.theta()), M_PI, 1e-6);
  EXPECT_THROW(solveWithOdometryChain(graph, {}), std::invalid_argument);
}

TEST(Experiments, UnknownExperimentIsAnError) {
  ExperimentOptions options;
  options.experiment = "tower11";
  options.output_dir = test::makeTempDir("storey_experiments_bad");
  try {
    runExperiments(options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tower11"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("buildings"), std::string::npos);  // where names come from
  }
  options.experiment = "../buildings/small2";  // a name, not a path
  EXPECT_THROW(runExperiments(options), std::invalid_argument);
  options.experiment = "tower10";
  options.domain_id = 230;
  options.jobs = 4;
  EXPECT_THROW(runExperiments(options), std::invalid_argument);  // domains beyond 232
}

// The options of one seed of one experiment, written to a fresh folder.
ExperimentOptions oneSeed(const std::string& experiment, std::uint64_t seed, int domain_id) {
  ExperimentOptions options;
  options.experiment = experiment;
  options.seeds = 1;
  options.first_seed = seed;
  options.domain_id = domain_id;
  options.output_dir = test::makeTempDir("storey_experiments");
  return options;
}

// One featureless seed end to end: its table, floors A and B.
ExperimentTable featurelessRun(std::uint64_t seed, int domain_id) {
  const auto tables = runExperiments(oneSeed("featureless", seed, domain_id));
  if (tables.size() != 1u || tables.front().floors.size() != 2u || tables.front().floors[1].floor != "B")
    throw std::runtime_error("featureless: expected one table with floors A and B");
  return tables.front();
}

// One tower10 seed end to end: the table's figures are those of a direct evaluation of
// the run's written trajectory against its ground truth.
TEST(Experiments, Tower10TableAgreesWithDirectEvaluation) {
  const ExperimentOptions options = oneSeed("tower10", 3, 78);
  const auto tables = runExperiments(options);
  ASSERT_EQ(tables.size(), 1u);
  const ExperimentTable& table = tables.front();
  ASSERT_EQ(table.runs.size(), 1u);
  const RunFigures& run = table.runs.front();
  EXPECT_EQ(run.seed, 3u);
  ASSERT_EQ(table.floors.size(), 10u);
  for (const char* file : {"experiments.md", "experiments.csv"})
    EXPECT_TRUE(fs::exists(fs::path(options.output_dir) / file)) << file;

  const fs::path dir = run.output_dir;
  const auto estimate = eval::readTrajectoryCsv((dir / "trajectory.csv").string());
  const auto truth = eval::readTrajectoryCsv((dir / "recording/ground_truth/trajectory.csv").string());
  const auto direct = eval::evaluate(estimate, truth,
                                     eval::readCorridors((dir / "recording/ground_truth/corridors.yaml").string()));
  ASSERT_EQ(direct.floors.size(), table.floors.size());
  std::size_t touching = 0;
  for (std::size_t i = 0; i < direct.floors.size(); ++i) {
    const FloorRow& row = table.floors[i];
    EXPECT_EQ(row.floor, direct.floors[i].floor);
    EXPECT_EQ(row.translation_with.count, 1u);
    // trajectory.csv holds the poses to the precision it prints them.
    EXPECT_NEAR(row.translation_with.mean, direct.floors[i].residual_translation, 1e-4) << row.floor;
    EXPECT_NEAR(row.rotation_with.mean, direct.floors[i].residual_rotation, 1e-4) << row.floor;
    EXPECT_DOUBLE_EQ(row.translation_with.std, 0.0);
    EXPECT_DOUBLE_EQ(row.translation_with.worst, row.translation_with.mean);
    const bool within = row.translation_with.worst <= options.goals.floor_translation &&
                        row.rotation_with.worst <= options.goals.floor_rotation;
    EXPECT_EQ(row.goal_met, within) << row.floor;
    touching += static_cast<std::size_t>(row.constraints.mean);
  }
  // A constraint is counted on both floors it joins.
  EXPECT_GT(table.constraints, 0u);
  EXPECT_EQ(table.constraints, run.constraints.size());
  std::size_t ends = 0;
  for (const auto& c : run.constraints)
    if (c.checked) ends += c.floor_from == c.floor_to ? 1 : 2;
  EXPECT_EQ(touching, ends);
  // The floors joined by odometry alone carry the elevator's heading errors; inter-floor
  // constraints must remove most of them.
  EXPECT_LT(run.with.ate_rmse, run.without.ate_rmse);
  EXPECT_GT(run.without.ate_rmse, 0.0);
  // The Markdown table names every floor and says whether the goal is met.
  std::ifstream md(fs::path(options.output_dir) / "experiments.md");
  std::stringstream text;
  text << md.rdbuf();
  for (const auto& row : table.floors) EXPECT_NE(text.str().find("| " + row.floor + " |"), std::string::npos);
  EXPECT_NE(text.str().find("every floor within 0.05 m / 0.2 deg"), std::string::npos);
}

// Any other building of config/buildings/ runs the same way, every floor judged against
// the alignment goal (small2, the bundled building: about 6 s).
TEST(Experiments, AnyBuildingRunsWithEveryFloorJudged) {
  const ExperimentOptions options = oneSeed("small2", 1, 76);
  const auto tables = runExperiments(options);
  ASSERT_EQ(tables.size(), 1u);
  const ExperimentTable& table = tables.front();
  EXPECT_EQ(table.spec.name, "small2");
  EXPECT_TRUE(table.spec.floor_goal);
  ASSERT_EQ(table.floors.size(), 2u);
  EXPECT_EQ(table.floors[0].floor, "F0");
  EXPECT_EQ(table.floors[1].floor, "F1");
  EXPECT_EQ(table.wrong, 0u);
  // 0.001 m / 0.048 deg at worst when written.
  for (const auto& row : table.floors) {
    EXPECT_TRUE(row.goal_met) << row.floor;
    EXPECT_LT(row.translation_with.worst, row.translation_without.worst) << row.floor;
  }
  EXPECT_TRUE(fs::exists(fs::path(options.output_dir) / "small2" / "seed_1" / "report.html"));
  std::ifstream md(fs::path(options.output_dir) / "experiments.md");
  std::stringstream text;
  text << md.rdbuf();
  EXPECT_NE(text.str().find("Not one of the paper's experiments"), std::string::npos);
}

// The fleet building end to end (three robots starting on F0, F0 and F3, all in one
// recording). Floor-graph ids are unique per robot and every detector knows the building's
// floor heights and its robot's start floor; with ids from 0 per robot the server would
// merge graphs of different robots and floors. 0.004 m / 0.031 deg when written.
TEST(Experiments, FleetMapsEveryRobotsFloorsIntoOneBuilding) {
  const auto tables = runExperiments(oneSeed("fleet", 1, 75));
  ASSERT_EQ(tables.size(), 1u);
  const ExperimentTable& table = tables.front();
  ASSERT_EQ(table.floors.size(), 4u);
  ASSERT_EQ(table.runs.size(), 1u);
  const fs::path building = fs::path(table.runs.front().output_dir) / "building.yaml";
  const YAML::Node written = YAML::LoadFile(building.string());
  EXPECT_EQ(written["floor_graphs"].size(), 6u);  // two floors per robot
  std::set<std::string> robots;
  for (const auto& g : written["floor_graphs"]) robots.insert(g["robot"].as<std::string>());
  EXPECT_EQ(robots.size(), 3u);
  // graph.g2o stays readable by g2o tools (32-bit vertex ids): floor graphs by rank.
  const graph::PoseGraph g2o = graph::readG2o((fs::path(table.runs.front().output_dir) / "graph.g2o").string());
  std::set<long long> ranks;
  for (const auto& node : g2o.nodes()) {
    EXPECT_LE(node.id, 2147483647LL);
    ranks.insert(node.id / building::BuildingGraph::kGraphIdStride);
  }
  EXPECT_EQ(ranks, (std::set<long long>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(table.wrong, 0u);
  for (const auto& row : table.floors) {
    EXPECT_GE(row.constraints.mean, 3.0) << row.floor;
    EXPECT_TRUE(row.goal_met) << row.floor << ": " << row.translation_with.worst << " m";
  }
}

// One glass3 seed end to end: every floor within the goal, with at least 3 constraints
// and none wrong. Its floors share only the lift and the 2 m x 4 m corridor before it.
void expectGlass3WithinTheGoal(std::uint64_t seed, int domain_id) {
  const auto tables = runExperiments(oneSeed("glass3", seed, domain_id));
  ASSERT_EQ(tables.size(), 1u);
  const ExperimentTable& table = tables.front();
  ASSERT_EQ(table.floors.size(), 3u);
  EXPECT_EQ(table.wrong, 0u);
  for (const auto& row : table.floors) {
    EXPECT_GE(row.constraints.mean, 3.0) << row.floor;
    EXPECT_TRUE(row.goal_met) << row.floor << ": " << row.translation_with.worst << " m, "
                              << row.rotation_with.worst * 180 / M_PI << " deg";
  }
}

// Seed 2: most of a glass3 floor's scans lie on walls the other floors lack, so the whole
// floor's points cannot refine a set's joint alignment; left at the likelihood field's
// refinement, F1 ends 0.37 deg off. Refined on the inliers' own points: every floor within
// 0.010 m / 0.10 deg when written.
TEST(Experiments, Glass3Seed2PlacesEveryFloorWithinTheGoal) { expectGlass3WithinTheGoal(2, 166); }

// Seed 12: F2, short of evidence against F0, was accepted against F1 on 3 candidates
// that fitted a look-alike turned 90 degrees about the lift (3 wrong constraints, F2 61 deg
// off). The robot's ride from F1 to F2 refutes that placement (floor_change_heading):
// every floor within 0.004 m / 0.10 deg when written, 10 constraints.
TEST(Experiments, Glass3Seed12IsNotPlacedAgainstTheRobotsRide) {
  expectGlass3WithinTheGoal(12, 167);
}

// featureless seed 7, end to end: floor B, a bare corridor whose ends and lobby differ,
// must not be taken for a symmetric floor (its own sequences find a 180 deg twin that fits
// the whole floor within the margin; the home sequences that refute the twin decide).
TEST(Experiments, FeaturelessFloorBIsPlacedOnSeed7) {
  const ExperimentTable table = featurelessRun(7, 79);
  const FloorRow& b = table.floors[1];
  EXPECT_GE(b.constraints.mean, 3.0);
  EXPECT_EQ(b.wrong, 0u);
  // Placed by its constraints: 0.021 m / 0.003 deg when written (unplaced it was 1.17 m /
  // 149 deg off).
  EXPECT_LT(b.translation_with.worst, 0.3);
  EXPECT_LT(b.rotation_with.worst, 0.2 * M_PI / 180.0);
}

// featureless seed 1, end to end. B's own graph is within 0.1 % and the constraints start
// in the elevator cabin (the landing's scans are mapped); the constraints must place B
// within the goal and leave its corridor as good as they found it. (A corridor mapped
// 0.8 % short needs ransac_distortion for its far candidates to join the rigid set.)
TEST(Experiments, FeaturelessSeed1PlacesFloorBWithinTheGoal) {
  const ExperimentTable table = featurelessRun(1, 77);
  const FloorRow& b = table.floors[1];
  EXPECT_EQ(b.wrong, 0u);
  EXPECT_GE(b.constraints.mean, 3.0);
  // The goal. (Joined by odometry alone, B can land within it too when the ride's heading
  // error is small, so the two are not compared.)
  EXPECT_LT(b.translation_with.worst, 0.05);
  EXPECT_LT(b.rotation_with.worst, 0.2 * M_PI / 180.0);
  bool measured = false;
  for (const CorridorRow& c : table.corridors) {
    if (c.name != "corridor_B") continue;
    measured = true;
    // -0.02 % when written, -0.09 % without inter-floor constraints.
    EXPECT_LT(c.abs_error_with.worst, 0.005);
    EXPECT_LT(c.abs_error_with.worst, c.abs_error_without.worst + 0.001);
  }
  EXPECT_TRUE(measured);
}

}  // namespace
}  // namespace storey::tools
