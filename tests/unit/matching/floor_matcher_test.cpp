#include "storey/matching/floor_matcher.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <numeric>
#include <sstream>

#include "matching_test_helpers.h"
#include "storey/common/config.h"
#include "storey/eval/simulated_floors.h"
#include "storey/localization/particle_filter.h"
#include "storey/matching/constraint_judgement.h"
#include "storey/matching/retraction.h"
#include "synthetic_floor.h"
#include "test_support.h"

namespace storey::matching {
namespace {

using geometry::Pose2;
using localization::LocalizationMap;
using localization::ParticleFilter;
using test::angleError;
using test::driveFloor;
using test::fastOptions;
using test::officeFloor;
using test::officePath;
using test::symmetricFloor;
using test::translationError;

TEST(FloorMatcher, RefinementRecoversAPerturbedAlignment) {
  const Pose2 frame(1.3, -0.7, 0.3);
  const auto ref = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 4);
  const auto g = driveFloor(officeFloor(0), officePath(1), frame, 1, 3.0, 5);
  const LocalizationMap map(floor::renderFloorMap(ref, {}), {});
  Pose2 alignment = frame * Pose2(0.12, -0.08, 0.03);
  const double fit = refineAlignment(map.field(), g, {{0, 15}}, 90, 50, &alignment);
  EXPECT_LT(translationError(alignment, frame), 0.02);
  EXPECT_LT(angleError(alignment, frame), 0.003);
  EXPECT_GT(fit, 0.5);
}

TEST(FloorMatcher, LearnedThresholdSeparatesOwnFloorFromWrongPoses) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 6);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  const FloorMatcherOptions o = fastOptions();
  const double l_min = learnLikelihoodThreshold(g, o, 1);
  EXPECT_GT(l_min, 0.0);
  ParticleFilter wrong(map, o.filter, 1);
  wrong.initializeAround(g.nodes[20].pose * Pose2(1.0, 0.0, 1.0), 0.0, 0.0, 10);
  EXPECT_LT(wrong.update(g.nodes[20].scan), l_min);
}

TEST(FloorMatcher, TwoFloorsWithSharedStructureAlign) {
  const Pose2 frame(1.3, -0.7, 0.3);  // floor 1's graph frame in floor 0's
  std::vector<floor::FloorGraph> graphs{
      driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8),
      driveFloor(officeFloor(1), officePath(1), frame, 1, 3.2, 9)};
  const MatchResult r = matchFloors(graphs, fastOptions());
  std::ostringstream report;
  printMatchReport(report, r);
  ASSERT_GE(r.constraints.size(), 3u) << report.str();
  for (const auto& c : r.constraints) {
    // Express every constraint as the floor alignment it implies, in floor 0's frame.
    const floor::FloorGraph& ref = graphs[c.reference_graph_id];
    const floor::FloorGraph& g = graphs[c.graph_id];
    const Pose2 implied = ref.findNode(c.reference_node_id)->pose * c.measurement *
                          g.findNode(c.node_id)->pose.inverse();
    const Pose2 truth = c.reference_graph_id == 0 ? frame : frame.inverse();
    EXPECT_LT(translationError(implied * g.findNode(c.node_id)->pose,
                               truth * g.findNode(c.node_id)->pose),
              0.1)
        << report.str();
    EXPECT_LT(angleError(implied, truth), 0.02);
    EXPECT_NEAR(c.dz, c.reference_graph_id == 0 ? 3.2 : -3.2, 1e-9);
  }
  const PairResult* pair = r.pairFor(r.reference_graph_id == 0 ? 1 : 0);
  ASSERT_NE(pair, nullptr);
  ASSERT_TRUE(pair->accepted);
  const Pose2 truth = r.reference_graph_id == 0 ? frame : frame.inverse();
  EXPECT_LT(translationError(pair->alignment, truth), 0.05) << report.str();
  EXPECT_LT(angleError(pair->alignment, truth), 0.0035);
}

// The office pair with floor 1's graph `scale` times too long: its scans are true, its
// node positions scaled, as a floor mapped with a scale error along it.
struct StretchedOfficePair {
  Pose2 frame{1.3, -0.7, 0.3};  // floor 1's true graph frame in floor 0's
  floor::FloorGraph floor1_true;
  std::vector<floor::FloorGraph> graphs;

  explicit StretchedOfficePair(double scale) {
    floor1_true = driveFloor(officeFloor(1), officePath(1), frame, 1, 3.2, 9);
    floor::FloorGraph stretched = floor1_true;
    for (auto& n : stretched.nodes)
      n.pose = Pose2(scale * n.pose.x(), scale * n.pose.y(), n.pose.theta());
    for (auto& e : stretched.edges)
      e.measurement = stretched.findNode(e.from)->pose.between(stretched.findNode(e.to)->pose);
    graphs = {driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8), stretched};
  }
  // A node's true pose in floor 0's frame.
  Pose2 truePose(int graph_id, int node_id) const {
    return graph_id == 0 ? graphs[0].findNode(node_id)->pose
                         : frame * floor1_true.findNode(node_id)->pose;
  }
  // Each constraint's translation error against its two nodes' true poses.
  std::vector<double> constraintErrors(const MatchResult& r) const {
    std::vector<double> e;
    for (const auto& c : r.constraints) {
      const Pose2 truth = truePose(c.reference_graph_id, c.reference_node_id)
                              .between(truePose(c.graph_id, c.node_id));
      e.push_back(translationError(c.measurement, truth));
    }
    return e;
  }
};

// A floor graph is not rigid: here floor 1's graph is 1 % too long, so one rigid
// alignment places its far end 0.2 m off. Each constraint that takes its translation from
// its own scans' fit says where those scans lie; through the joint alignment it says
// where the rigid floor would put them.
TEST(FloorMatcher, ConstraintsOfAStretchedFloorSayWhereTheirOwnScansLie) {
  const StretchedOfficePair pair(1.01);
  auto errors = [&](bool local) {
    FloorMatcherOptions o = fastOptions();
    o.local_constraint_translation = local;
    return pair.constraintErrors(matchFloors(pair.graphs, o));
  };
  const std::vector<double> joint = errors(false), local = errors(true);
  ASSERT_GE(local.size(), 3u);
  ASSERT_EQ(local.size(), joint.size());
  const double joint_mean = std::accumulate(joint.begin(), joint.end(), 0.0) / joint.size();
  const double local_mean = std::accumulate(local.begin(), local.end(), 0.0) / local.size();
  const double local_max = *std::max_element(local.begin(), local.end());
  std::printf(
      "%zu constraints: through the joint alignment %.3f m (worst %.3f), local %.3f m (worst "
      "%.3f)\n",
      local.size(), joint_mean, *std::max_element(joint.begin(), joint.end()), local_mean,
      local_max);
  EXPECT_LT(local_mean, 0.5 * joint_mean);
  EXPECT_LT(local_max, 0.05);
}

// A corridor graph 1 % short: the rigid set anchors it over its first 10 m, where its
// candidates agree; 60 m further on a right candidate is 0.7 m off the rigid alignment,
// within 0.3 m + 2 % of 60 m. A candidate as far off beside the set, or one turned by
// more than the rotation tolerance, gets no allowance; without ransac_distortion none does.
TEST(FloorMatcher, ABentFloorsFarCandidateJoinsTheRigidSetButNotOneBesideIt) {
  floor::FloorGraph g;
  for (int i = 0; i <= 80; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.pose = Pose2(static_cast<double>(i), 0.0, 0.0);
    g.nodes.push_back(n);
  }
  const Pose2 rigid(5.0, 2.0, 0.1);
  auto candidate = [&](int node, const Pose2& alignment) {
    Candidate c;
    c.node_index = node;
    c.alignment = alignment;
    return c;
  };
  const Pose2 shifted(rigid.x() + 0.7 * std::cos(rigid.theta()),
                      rigid.y() + 0.7 * std::sin(rigid.theta()),
                      rigid.theta());  // places every node 0.7 m further along
  const std::vector<Candidate> cands{
      candidate(0, rigid),
      candidate(5, rigid),
      candidate(10, rigid),                                               // the rigid set
      candidate(70, shifted),                                             // 60 m on: joins
      candidate(12, shifted),                                             // 2 m on: does not
      candidate(75, Pose2(rigid.x(), rigid.y(), rigid.theta() + 0.08))};  // turned: does not
  const std::vector<std::size_t> pool{0, 1, 2, 3, 4, 5}, core{0, 1, 2};
  FloorMatcherOptions o;
  o.ransac_distortion = 0.02;
  EXPECT_EQ(bentFloorCandidates(cands, pool, core, g, o), (std::vector<std::size_t>{3}));
  o.ransac_distortion = 0.0;
  EXPECT_TRUE(bentFloorCandidates(cands, pool, core, g, o).empty());
  o.ransac_distortion = 0.005;  // 0.3 + 0.3 m at 60 m: not enough for 0.7 m
  EXPECT_TRUE(bentFloorCandidates(cands, pool, core, g, o).empty());
}

// A floor visited twice is one graph; between the visits the robot's odometry ran on
// through the rides, so it jumps where the second visit starts. The scans are replayed
// with the poses the graph first gave its nodes, so the jump changes nothing: here it
// comes after each graph's third node, inside the first sequence of either graph.
TEST(FloorMatcher, AFloorVisitedTwiceMatchesAsIfItsOdometryHadNotJumped) {
  const Pose2 frame(1.3, -0.7, 0.3);
  const std::vector<floor::FloorGraph> graphs{
      driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8),
      driveFloor(officeFloor(1), officePath(1), frame, 1, 3.2, 9)};
  std::vector<floor::FloorGraph> jumped = graphs;
  const Pose2 away(35.0, -12.0, 2.5);  // where the odometry went meanwhile
  for (auto& g : jumped)
    for (std::size_t i = 3; i < g.nodes.size(); ++i)
      g.nodes[i].odometry = away * g.nodes[i].odometry;
  const MatchResult a = matchFloors(graphs, fastOptions());
  const MatchResult b = matchFloors(jumped, fastOptions());
  std::ostringstream report;
  printMatchReport(report, b);
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (std::size_t p = 0; p < a.pairs.size(); ++p) {
    EXPECT_EQ(a.pairs[p].accepted, b.pairs[p].accepted);
    EXPECT_EQ(a.pairs[p].sequences, b.pairs[p].sequences);
    ASSERT_EQ(a.pairs[p].candidates.size(), b.pairs[p].candidates.size()) << report.str();
    for (std::size_t i = 0; i < a.pairs[p].candidates.size(); ++i) {
      const Candidate &ca = a.pairs[p].candidates[i], &cb = b.pairs[p].candidates[i];
      EXPECT_EQ(ca.first_index, cb.first_index);
      EXPECT_EQ(ca.last_index, cb.last_index);
      EXPECT_EQ(ca.status, cb.status);
      EXPECT_EQ(ca.measurement.vector(), cb.measurement.vector());
    }
  }
  EXPECT_EQ(a.constraints.size(), b.constraints.size());
  ASSERT_GE(b.constraints.size(), 3u) << report.str();
}

TEST(FloorMatcher, SameSeedSameResult) {
  std::vector<floor::FloorGraph> graphs{
      driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8),
      driveFloor(officeFloor(1), officePath(1), Pose2(1.3, -0.7, 0.3), 1, 3.2, 9)};
  const MatchResult a = matchFloors(graphs, fastOptions());
  const MatchResult b = matchFloors(graphs, fastOptions());
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  EXPECT_EQ(a.beam_evaluations, b.beam_evaluations);
  for (std::size_t p = 0; p < a.pairs.size(); ++p) {
    ASSERT_EQ(a.pairs[p].candidates.size(), b.pairs[p].candidates.size());
    for (std::size_t i = 0; i < a.pairs[p].candidates.size(); ++i) {
      const Candidate &ca = a.pairs[p].candidates[i], &cb = b.pairs[p].candidates[i];
      EXPECT_EQ(ca.first_index, cb.first_index);
      EXPECT_EQ(ca.last_index, cb.last_index);
      EXPECT_EQ(ca.reference_node_id, cb.reference_node_id);
      EXPECT_EQ(ca.likelihood, cb.likelihood);
      EXPECT_EQ(ca.measurement.vector(), cb.measurement.vector());
      EXPECT_EQ(ca.status, cb.status);
    }
  }
}

// Two robots' graphs of that floor, each seeing all of it (a part seen by one robot only
// is not ambiguous to it: the data could not tell its twin apart).
std::vector<floor::FloorGraph> symmetricFloorGraphs() {
  const std::vector<Eigen::Vector2d> path0{{1, 1.5}, {1, 6.5},  {7, 6.5},  {7, 4},   {9, 4},
                                           {9, 6.5}, {15, 6.5}, {15, 1.5}, {9, 1.5}, {9, 4},
                                           {7, 4},   {7, 1.5},  {1.5, 1.5}};
  const std::vector<Eigen::Vector2d> path1{{2, 6.5}, {2, 2},  {6.5, 2}, {6.5, 4}, {9.5, 4},
                                           {9.5, 2}, {14, 2}, {14, 6},  {9.5, 6}, {9.5, 4.2}};
  return {driveFloor(symmetricFloor(), path0, Pose2(), 0, 0.0, 12),
          driveFloor(symmetricFloor(), path1, Pose2(0.5, 0.2, -0.2), 1, 3.0, 13)};
}

TEST(FloorMatcher, SymmetricFloorsGiveNoConstraint) {
  const std::vector<floor::FloorGraph> graphs = symmetricFloorGraphs();
  const MatchResult r = matchFloors(graphs, fastOptions());
  std::ostringstream report;
  printMatchReport(report, r);
  EXPECT_TRUE(r.constraints.empty()) << report.str();
}

TEST(FloorMatcher, MatchedAnywayAFullySymmetricFloorStillGivesNoConstraint) {
  // With match_self_similar the two self-similar floors are matched, but every sequence
  // fits its twin alignment as well as its own (the floor is symmetric everywhere): each
  // gated candidate is marked ambiguous and none becomes a constraint.
  const std::vector<floor::FloorGraph> graphs = symmetricFloorGraphs();
  FloorMatcherOptions o = fastOptions();
  o.match_self_similar = true;
  const MatchResult r = matchFloors(graphs, o);
  std::ostringstream report;
  printMatchReport(report, r);
  EXPECT_TRUE(r.constraints.empty()) << report.str();
  int twins = 0;
  for (const auto& p : r.pairs)
    for (const auto& c : p.candidates) {
      twins += c.reason.find("twin alignment") != std::string::npos;
      // A twin's candidate stays ambiguous through the pair's second pass, and a
      // first-pass one is not re-localised by the wall recheck (its see-through is unset).
      if (!c.fits_twin) continue;
      EXPECT_EQ(c.status, CandidateStatus::kAmbiguous) << report.str();
      if (!c.reversed && !c.backwards) {
        EXPECT_EQ(c.see_through, -1.0) << report.str();
      }
    }
  // The floors are found self-similar (both, in this build; the sanitizer build's floating
  // point may differ), matched anyway, and their candidates are refused as twins, not
  // merely too few.
  std::cout << "self-similar: " << r.floors[0].self_similar << ", " << r.floors[1].self_similar
            << "; candidates marked as twins: " << twins << "\n";
  if (r.floors[0].self_similar && r.floors[1].self_similar) {
    EXPECT_FALSE(r.pairs.empty()) << report.str();
    EXPECT_GT(twins, 0) << report.str();
  }
}
}  // namespace
}  // namespace storey::matching
