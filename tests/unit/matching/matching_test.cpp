#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <numeric>
#include <sstream>

#include "storey/common/config.h"
#include "storey/eval/simulated_floors.h"
#include "storey/localization/particle_filter.h"
#include "storey/matching/constraint_judgement.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/retraction.h"
#include "synthetic_floor.h"
#include "test_support.h"

namespace storey::matching {
namespace {

using eval::SimulatedFloors;

using geometry::Pose2;
using localization::FilterState;
using localization::LocalizationMap;
using localization::makeWallModel;
using localization::ParticleFilter;
using localization::ParticleFilterOptions;
using localization::selectBeams;
using localization::WallModel;
using test::driveFloor;
using test::officeFloor;
using test::officePath;

double angleError(const Pose2& a, const Pose2& b) {
  return std::abs(geometry::angleDiff(a.theta(), b.theta()));
}
double translationError(const Pose2& a, const Pose2& b) {
  return (a.translation() - b.translation()).norm();
}

FloorMatcherOptions fastOptions() {
  FloorMatcherOptions o;
  o.seed = 7;
  o.filter.coarse_beams = 20;  // as config/floor_matcher.yaml
  return o;
}

TEST(ParticleFilter, UniformInitialisationIsInFreeSpaceAndSizedByArea) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 1);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilterOptions o;
  o.initial_particles_per_m2 = 10.0;
  ParticleFilter pf(map, o, 3);
  pf.initializeUniform();
  const double expected = std::clamp(map.freeArea() * 10.0, 300.0, 50000.0);
  EXPECT_NEAR(static_cast<double>(pf.size()), expected, 1.0);
  for (std::size_t j = 0; j < pf.size(); ++j) EXPECT_TRUE(map.isFree(pf.xs()[j], pf.ys()[j]));
  EXPECT_FALSE(pf.state().converged);
}

TEST(ParticleFilter, GlobalLocalisationConvergesToTheTruePoseAndShrinks) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 2);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilter pf(map, {}, 11);
  pf.initializeUniform();
  const std::size_t initial = pf.size();
  bool converged = false;
  for (std::size_t n = 0; n < 40 && n < g.nodes.size(); ++n) {
    if (n > 0) pf.predict(g.nodes[n - 1].odometry.between(g.nodes[n].odometry));
    pf.update(g.nodes[n].scan);
    const FilterState s = pf.state();
    if (n >= 2 && s.converged) {
      EXPECT_LT(translationError(s.mean, g.nodes[n].pose), 0.3) << "node " << n;
      EXPECT_LT(angleError(s.mean, g.nodes[n].pose), 0.1);
      converged = true;
      break;
    }
    pf.resampleIfNeeded();
  }
  EXPECT_TRUE(converged);
  EXPECT_LT(pf.size(), initial / 4) << "KLD-sampling should shrink a converged filter";
}

// Coarse-to-fine: the global phase with few beams must still converge to the truth, and
// use fewer particle-beam evaluations than the same filter with every beam.
TEST(ParticleFilter, CoarseBeamsInTheGlobalPhaseStillConverge) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 2);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  std::uint64_t evaluations[2] = {0, 0};
  for (int coarse = 0; coarse < 2; ++coarse) {
    ParticleFilterOptions o;
    o.initial_particles_per_m2 = 200.0;  // a global phase well above coarse_particles
    o.coarse_beams = coarse ? 15 : 0;
    o.coarse_particles = 2000;
    ParticleFilter pf(map, o, 11);
    pf.initializeUniform();
    ASSERT_GT(pf.size(), 2000u);
    bool converged = false;
    for (std::size_t n = 0; n < 40 && n < g.nodes.size(); ++n) {
      if (n > 0) pf.predict(g.nodes[n - 1].odometry.between(g.nodes[n].odometry));
      pf.update(g.nodes[n].scan);
      const FilterState s = pf.state();
      if (n >= 2 && s.converged) {
        EXPECT_LT(translationError(s.mean, g.nodes[n].pose), 0.3) << "coarse " << coarse;
        EXPECT_LT(angleError(s.mean, g.nodes[n].pose), 0.1) << "coarse " << coarse;
        converged = true;
        break;
      }
      pf.resampleIfNeeded();
    }
    EXPECT_TRUE(converged) << "coarse " << coarse;
    evaluations[coarse] = pf.beamEvaluations();
  }
  EXPECT_LT(evaluations[1], evaluations[0]);
}

TEST(ParticleFilter, LikelihoodIsHigherAtTheTruePose) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 3);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  ParticleFilter right(map, {}, 1), wrong(map, {}, 1);
  const Pose2 truth = g.nodes[10].pose;
  right.initializeAround(truth, 0.0, 0.0, 10);
  wrong.initializeAround(truth * Pose2(0.0, 0.0, 0.5), 0.0, 0.0, 10);
  EXPECT_GT(right.update(g.nodes[10].scan), 2.0 * wrong.update(g.nodes[10].scan));
  EXPECT_EQ(right.beamEvaluations(), 10u * 60u);
}

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
    for (auto& n : stretched.nodes) n.pose = Pose2(scale * n.pose.x(), scale * n.pose.y(), n.pose.theta());
    for (auto& e : stretched.edges)
      e.measurement = stretched.findNode(e.from)->pose.between(stretched.findNode(e.to)->pose);
    graphs = {driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8), stretched};
  }
  // A node's true pose in floor 0's frame.
  Pose2 truePose(int graph_id, int node_id) const {
    return graph_id == 0 ? graphs[0].findNode(node_id)->pose : frame * floor1_true.findNode(node_id)->pose;
  }
  // Each constraint's translation error against its two nodes' true poses.
  std::vector<double> constraintErrors(const MatchResult& r) const {
    std::vector<double> e;
    for (const auto& c : r.constraints) {
      const Pose2 truth = truePose(c.reference_graph_id, c.reference_node_id).between(truePose(c.graph_id, c.node_id));
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
  std::printf("%zu constraints: through the joint alignment %.3f m (worst %.3f), local %.3f m (worst %.3f)\n",
              local.size(), joint_mean, *std::max_element(joint.begin(), joint.end()), local_mean, local_max);
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
  const Pose2 shifted(rigid.x() + 0.7 * std::cos(rigid.theta()), rigid.y() + 0.7 * std::sin(rigid.theta()),
                      rigid.theta());  // places every node 0.7 m further along
  const std::vector<Candidate> cands{
      candidate(0, rigid), candidate(5, rigid), candidate(10, rigid),  // the rigid set
      candidate(70, shifted),                                          // 60 m on: joins
      candidate(12, shifted),                                          // 2 m on: does not
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

// When g_i's own sequences are not enough, g_ref's scans localised in g_i's map join the
// RANSAC; they must read exactly like forward candidates (alignment of g_i in g_ref, and
// a constraint from a g_ref node to a g_i node).
TEST(FloorMatcher, BothDirectionsAddReversedCandidatesThatReadAsForwardOnes) {
  const Pose2 frame(1.3, -0.7, 0.3);  // floor 1's graph frame in floor 0's
  const floor::FloorGraph g0 = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8);
  const floor::FloorGraph g1 = driveFloor(officeFloor(1), officePath(1), frame, 1, 3.2, 9);
  FloorMatcherOptions o = fastOptions();
  const PreparedFloor ref = prepareFloor(g0, o), other = prepareFloor(g1, o);
  o.match_both_directions = false;
  const PairResult forward = matchPair(ref, other, o, 3);
  int forward_consistent = 0;
  for (const auto& c : forward.candidates)
    forward_consistent += c.status == CandidateStatus::kAccepted;
  ASSERT_GE(forward_consistent, 1);
  // Ask for more than one direction can give.
  o.min_constraints = forward_consistent + 1;
  o.match_both_directions = true;
  const PairResult both = matchPair(ref, other, o, 3);
  std::ostringstream report;
  MatchResult wrapped;
  wrapped.pairs.push_back(both);
  printMatchReport(report, wrapped);
  EXPECT_GT(both.reversed_candidates, 0) << report.str();
  ASSERT_TRUE(both.accepted) << report.str();
  int reversed_accepted = 0;
  for (const auto& c : both.candidates) {
    if (c.status != CandidateStatus::kAccepted) continue;
    reversed_accepted += c.reversed;
    EXPECT_EQ(c.reference_graph_id, 0);
    EXPECT_EQ(c.graph_id, 1);
    EXPECT_NEAR(c.dz, 3.2, 1e-9);
    const Pose2& pk = g1.findNode(c.node_id)->pose;
    EXPECT_EQ(g1.nodes[c.node_index].id, c.node_id);
    EXPECT_LT(translationError(c.alignment * pk, frame * pk), 0.1) << report.str();
    const Pose2 implied = g0.findNode(c.reference_node_id)->pose * c.measurement * pk.inverse();
    EXPECT_LT(translationError(implied * pk, frame * pk), 0.1) << report.str();
    EXPECT_LT(angleError(implied, frame), 0.02) << report.str();
  }
  EXPECT_GT(reversed_accepted, 0) << report.str();
  EXPECT_LT(translationError(both.alignment, frame), 0.05) << report.str();
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

// A floor with 180-degree rotational symmetry: every pose has a twin.
test::Walls symmetricFloor() {
  test::Walls w;
  test::addBox(&w, 0, 0, 16, 8);
  test::addBox(&w, 3, 3, 5, 5);
  test::addBox(&w, 11, 3, 13, 5);
  test::addWall(&w, 8, 0, 8, 2.5);
  test::addWall(&w, 8, 5.5, 8, 8);
  return w;
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

// A bare corridor whose ends and lobby differ (featureless floor B in miniature): bare
// stretches localise either way round, so the floor's own scans find a 180-degree twin,
// but the sequences at the ends and the lobby do not fit it.
test::Walls corridorWithDistinctEnds(double length) {
  const double mid = length / 2;
  test::Walls w;
  test::addWall(&w, 0, 0, length, 0);
  test::addWall(&w, 0, 3, mid - 1, 3);
  test::addWall(&w, mid + 1, 3, length, 3);
  test::addWall(&w, 0, 0, 0, 3);
  test::addWall(&w, length, 0, length, 3);
  test::addWall(&w, mid - 1, 3, mid - 1, 5.5);  // a shaft behind the lobby's opening
  test::addWall(&w, mid - 1, 5.5, mid + 1, 5.5);
  test::addWall(&w, mid + 1, 5.5, mid + 1, 3);
  test::addBox(&w, 2.5, 2.3, 3.5, 2.7);                    // furniture at the west end, north side
  test::addBox(&w, length - 3.5, 2.3, length - 2.5, 2.7);  // and at the east end, north side
  test::addBox(&w, mid - 4, 0, mid - 2, 0.5);              // a bench in the lobby, south side
  return w;
}

TEST(FloorMatcher, ABareCorridorWithDistinctEndsIsNotSelfSimilar) {
  const double length = 120.0;
  const std::vector<Eigen::Vector2d> path{
      {length / 2, 1.5}, {length - 1.5, 1.5}, {1.5, 1.5}, {length / 2 - 1, 1.5}};
  const auto g = driveFloor(corridorWithDistinctEnds(length), path, Pose2(), 0, 0.0, 24);
  FloorMatcherOptions o = fastOptions();
  // Here 6 own sequences find the 180-degree twin against 16 at home (4 against 18 in the
  // sanitizer build, whose floating point differs); featureless floor B (seed 7) had 5
  // against 10. A ratio of 0.2 lets this twin count as that one did, in either build.
  o.ambiguity_ratio = 0.2;
  const FloorCheck check = checkSelfSimilarity(prepareFloor(g, o), o, 5);
  MatchResult r;
  r.floors.push_back(check);
  std::ostringstream report;
  printMatchReport(report, r);
  std::cout << report.str();
  // The twin is found, and the whole floor fits it within the margin (a long bare
  // corridor fits either way round): by those tests alone the floor is self-similar.
  ASSERT_GE(check.elsewhere, std::max(2.0, o.ambiguity_ratio * check.at_identity)) << report.str();
  ASSERT_LT(check.fit_identity, check.fit_elsewhere + o.ambiguity_fit_margin) << report.str();
  // But most sequences at home, those at the ends and the lobby, fit it clearly worse.
  EXPECT_GE(check.refuted, std::max(2.0, o.ambiguity_ratio * check.elsewhere)) << report.str();
  EXPECT_FALSE(check.self_similar) << report.str();

  // With the same options, a floor that is symmetric everywhere still is.
  const std::vector<Eigen::Vector2d> around{{1, 1.5}, {1, 6.5},  {7, 6.5}, {7, 4},   {9, 4},
                                            {9, 6.5}, {15, 6.5}, {15, 1.5}, {9, 1.5}, {9, 4},
                                            {7, 4},   {7, 1.5},  {1.5, 1.5}};
  const auto sym = driveFloor(symmetricFloor(), around, Pose2(), 0, 0.0, 12);
  const FloorCheck twin = checkSelfSimilarity(prepareFloor(sym, o), o, 5);
  r.floors = {twin};
  report.str("");
  printMatchReport(report, r);
  std::cout << report.str();
  EXPECT_TRUE(twin.self_similar) << report.str();
}

TEST(FloorMatcher, UnrelatedFloorsGiveNoConstraint) {
  test::Walls other;
  test::addBox(&other, 0, 0, 9, 30);
  test::addWall(&other, 0, 10, 6, 10);
  test::addWall(&other, 3, 20, 9, 20);
  test::addBox(&other, 4, 4, 5, 6);
  const std::vector<Eigen::Vector2d> path{{1.5, 1}, {1.5, 28}, {7.5, 28}, {7.5, 1}};
  std::vector<floor::FloorGraph> graphs{
      driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 14),
      driveFloor(other, path, Pose2(), 1, 3.0, 15)};
  const MatchResult r = matchFloors(graphs, fastOptions());
  std::ostringstream report;
  printMatchReport(report, r);
  EXPECT_TRUE(r.constraints.empty()) << report.str();
}

// A 10 m x 5 m frame with one wall one cell thick at x = 5 m, from y = 1 to 4 m.
grid::GridFrame wallFrame(std::vector<std::uint8_t>* walls) {
  grid::GridFrame f;
  f.resolution = 0.05;
  f.width = 200;
  f.height = 100;
  walls->assign(f.cellCount(), 0);
  for (int cy = 20; cy < 80; ++cy) (*walls)[f.index(100, cy)] = 1;
  return f;
}

TEST(WallModel, FindsTheWallsASegmentCrossesAndNoOthers) {
  std::vector<std::uint8_t> walls;
  const grid::GridFrame f = wallFrame(&walls);
  const WallModel model = makeWallModel(f, walls);
  EXPECT_FLOAT_EQ(model.distance[f.index(100, 50)], 0.0f);
  EXPECT_NEAR(model.distance[f.index(90, 50)], 0.5, 0.05);  // chamfer, within 8 %
  EXPECT_TRUE(model.crosses({1.0, 2.5}, {8.0, 2.5}));
  EXPECT_FALSE(model.crosses({1.0, 2.5}, {4.9, 2.5}));  // stops short of it
  EXPECT_FALSE(model.crosses({1.0, 0.5}, {8.0, 0.5}));  // passes below its end
  EXPECT_FALSE(model.crosses({5.5, 2.5}, {9.5, 4.5}));  // starts beyond it
  EXPECT_TRUE(model.crosses({9.0, 3.9}, {1.0, 1.1}));   // diagonal, right to left
  // Every segment through the wall's middle at up to 60 degrees from its normal, with
  // random ends in open space on both sides, is caught (sphere tracing must not step over
  // a wall one cell thick).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> y(1.8, 3.2), angle(-1.05, 1.05), length(0.3, 4.5);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector2d at(5.025, y(rng));
    const double a = angle(rng);
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    const Eigen::Vector2d from = at - std::min(length(rng), 4.9 / u.x()) * u;
    const Eigen::Vector2d to = at + std::min(length(rng), 4.9 / u.x()) * u;
    ASSERT_TRUE(model.crosses(from, to)) << "from " << from.transpose() << " to " << to.transpose();
  }
}

// One node's scan: beams over +-0.2 rad ending on the vertical line x = `wall_x` (robot at
// the origin, heading 0).
floor::FloorNode nodeSeeingWallAt(int id, double wall_x) {
  floor::FloorNode n;
  n.id = id;
  n.scan.angle_min = -0.2;
  n.scan.angle_increment = 0.002;  // dense enough that the mapped walls have no gaps
  n.scan.range_min = 0.05;
  n.scan.range_max = 30.0;
  for (int b = 0; b <= 200; ++b)
    n.scan.ranges.push_back(static_cast<float>(wall_x / std::cos(n.scan.angle(b))));
  return n;
}

TEST(SolidWalls, AWallTheFloorsOwnBeamsPassedIsNotSolid) {
  // A door at x = 2 m, shut for three scans and open for one (which sees the wall at 4 m).
  floor::FloorGraph g;
  for (int i = 0; i < 3; ++i) g.nodes.push_back(nodeSeeingWallAt(i, 2.0));
  g.nodes.push_back(nodeSeeingWallAt(3, 4.0));
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  const grid::GridFrame& f = map.frame();
  const Eigen::Vector2i door = f.cellOf({2.02, 0.0}), far = f.cellOf({4.02, 0.0});
  ASSERT_FLOAT_EQ(map.field().distance().at(door.x(), door.y()), 0.0f) << "the door is mapped";
  const std::vector<std::uint8_t> walls = solidWalls(map.field(), g, 90);
  EXPECT_EQ(walls[f.index(door.x(), door.y())], 0);
  EXPECT_EQ(walls[f.index(far.x(), far.y())], 1);
  // Seen from 1 m further on, the open-door scan sees through no solid wall; put 3 m
  // back, it would (its beams end 1 m beyond the far wall).
  EXPECT_DOUBLE_EQ(seeThroughFraction(f, walls, g, {{3, 3}}, 90, Pose2(), 0.3), 0.0);
  EXPECT_GT(seeThroughFraction(f, walls, g, {{3, 3}}, 90, Pose2(1.0, 0.0, 0.0), 0.3), 0.9);
}

// A corridor 36 m long with a row of identical rooms every 6 m on its north side: locally
// periodic, but its end walls tell the rooms apart.
test::Walls periodicRowFloor() {
  test::Walls w;
  test::addWall(&w, 0, 0, 36, 0);
  test::addWall(&w, 0, 0, 0, 2.5);
  test::addWall(&w, 36, 0, 36, 2.5);
  double from = 0.0;
  for (int k = 0; k < 6; ++k) {
    const double door = 6.0 * k + 3.0;  // a 1 m door in the middle of each room
    test::addWall(&w, from, 2.5, door - 0.5, 2.5);
    from = door + 0.5;
    test::addWall(&w, door - 2.0, 2.5, door - 2.0, 6.5);
    test::addWall(&w, door + 2.0, 2.5, door + 2.0, 6.5);
    test::addWall(&w, door - 2.0, 6.5, door + 2.0, 6.5);
  }
  test::addWall(&w, from, 2.5, 36, 2.5);
  return w;
}

// In periodicRowFloor: a robot mapping the west end (rooms at 3 and 9 m) or the east end
// (rooms at 27 and 33 m), with a building-scale laser that sees the corridor's far end.
floor::FloorGraph periodicRowGraph(bool west, const Pose2& frame, int graph_id, double height,
                                   unsigned seed) {
  const std::vector<Eigen::Vector2d> west_path{{1.5, 1.25}, {9, 1.25}, {9, 4.5}, {9, 1.25},
                                               {3, 1.25},   {3, 4.5},  {3, 1.25}};
  const std::vector<Eigen::Vector2d> east_path{{34.5, 1.25}, {27, 1.25}, {27, 4.5}, {27, 1.25},
                                               {33, 1.25},   {33, 4.5},  {33, 1.25}};
  test::DriveOptions drive;
  drive.range_max = 40.0;
  return driveFloor(periodicRowFloor(), west ? west_path : east_path, frame, graph_id, height, seed,
                    drive);
}

TEST(SameFloorContradiction, TwoRobotsGraphsOfOneFloorAreNotPlacedRoomsApart) {
  // Robot A maps the west end (rooms at 3 and 9 m), robot B the east end (rooms at 27 and
  // 33 m): they share no structure, but B's graph shifted 6, 12, 18 or 24 m west puts one
  // or both of its rooms on A's.
  const Pose2 frame_a(2.0, -1.0, 0.3), frame_b(-5.0, 4.0, -1.1);
  floor::FloorGraph a = periodicRowGraph(true, frame_a, 0, 0.0, 21);
  floor::FloorGraph b = periodicRowGraph(false, frame_b, 1, 0.0, 22);
  a.floor_id = b.floor_id = 2;
  const FloorMatcherOptions o = fastOptions();
  const PreparedFloor prepared_a = prepareFloor(a, o), prepared_b = prepareFloor(b, o);
  const Pose2 truth = frame_a.inverse() * frame_b;  // B's frame in A's
  EXPECT_EQ(sameFloorContradiction(prepared_a, prepared_b, truth, o), "");
  EXPECT_EQ(sameFloorContradiction(prepared_b, prepared_a, truth.inverse(), o), "");
  for (double shift : {-6.0, -12.0, -18.0, -24.0}) {
    const Pose2 rooms_apart = frame_a.inverse() * Pose2(shift, 0.0, 0.0) * frame_b;
    const std::string why = sameFloorContradiction(prepared_a, prepared_b, rooms_apart, o);
    EXPECT_NE(why.find("are of floor 2"), std::string::npos) << shift << " m: " << why;
    EXPECT_NE(sameFloorContradiction(prepared_b, prepared_a, rooms_apart.inverse(), o), "")
        << shift << " m";
  }
  // Without the check, the matcher places B 18 m west (its room at 27 m on A's at 9 m);
  // with it, that alignment is contradicted and no constraint is made.
  FloorMatcherOptions off = o;
  off.same_floor_see_through = 1.0;
  const MatchResult unchecked = matchFloors({a, b}, off);
  ASSERT_FALSE(unchecked.constraints.empty());
  const PairResult* placed = unchecked.pairFor(1);
  ASSERT_NE(placed, nullptr);
  EXPECT_GT(
      translationError(placed->alignment * b.nodes.front().pose, truth * b.nodes.front().pose),
      5.0);
  const MatchResult checked = matchFloors({a, b}, o);
  std::ostringstream report;
  printMatchReport(report, checked);
  EXPECT_TRUE(checked.constraints.empty()) << report.str();
  EXPECT_NE(report.str().find("contradicted"), std::string::npos) << report.str();
  // Different floors may differ in their walls: the check does not apply to them.
  b.floor_id = 3;
  const PreparedFloor other_floor = prepareFloor(b, o);
  EXPECT_EQ(sameFloorContradiction(prepared_a, other_floor,
                                   frame_a.inverse() * Pose2(-18.0, 0.0, 0.0) * frame_b, o),
            "");
}

// A pass that placed each of two graphs of one floor through a third graph: one accepted
// pair each, with one constraint that puts the graph where `alignment` says.
PairResult placedThrough(const floor::FloorGraph& reference, const floor::FloorGraph& g,
                         const Pose2& alignment) {
  PairResult p;
  p.reference_graph_id = reference.graph_id;
  p.graph_id = g.graph_id;
  p.accepted = true;
  p.alignment = alignment;
  Candidate c;
  c.reference_graph_id = reference.graph_id;
  c.graph_id = g.graph_id;
  c.node_index = 0;
  c.node_id = g.nodes.front().id;
  c.reference_node_id = reference.nodes.front().id;
  c.measurement = reference.nodes.front().pose.between(alignment * g.nodes.front().pose);
  c.alignment = alignment;
  c.status = CandidateStatus::kAccepted;
  p.candidates.push_back(c);
  return p;
}

TEST(SameFloorContradiction, GraphsOfOneFloorPlacedThroughAnotherFloorAreCheckedAgainstEachOther) {
  // A and B as above (floor 2); R, a graph of the west end on floor 7, placed A right and
  // B 18 m west (its rooms on another floor's look-alike ones).
  const Pose2 frame_a(2.0, -1.0, 0.3), frame_b(-5.0, 4.0, -1.1), frame_r(1.0, 1.0, 0.5);
  std::vector<floor::FloorGraph> graphs{periodicRowGraph(true, frame_r, 7, 10.0, 20),
                                        periodicRowGraph(true, frame_a, 0, 0.0, 21),
                                        periodicRowGraph(false, frame_b, 1, 0.0, 22)};
  graphs[1].floor_id = graphs[2].floor_id = 2;
  const FloorMatcherOptions o = fastOptions();
  std::vector<PreparedFloor> prepared;
  for (const auto& g : graphs) prepared.push_back(prepareFloor(g, o));
  auto passPlacingB = [&](const Pose2& b_in_building) {
    MatchResult r;
    r.pairs.push_back(placedThrough(graphs[0], graphs[1], frame_r.inverse() * frame_a));
    r.pairs.push_back(placedThrough(graphs[0], graphs[2], frame_r.inverse() * b_in_building));
    for (const auto& p : r.pairs) {
      InterFloorConstraint c;
      c.reference_graph_id = p.reference_graph_id;
      c.graph_id = p.graph_id;
      c.reference_node_id = p.candidates[0].reference_node_id;
      c.node_id = p.candidates[0].node_id;
      c.measurement = p.candidates[0].measurement;
      r.constraints.push_back(c);
    }
    return r;
  };
  MatchResult right = passPlacingB(frame_b);
  EXPECT_FALSE(rejectContradictedPlacements(graphs, prepared, o, &right));
  EXPECT_TRUE(right.pairs[0].accepted && right.pairs[1].accepted);
  MatchResult wrong = passPlacingB(Pose2(-18.0, 0.0, 0.0) * frame_b);
  EXPECT_TRUE(rejectContradictedPlacements(graphs, prepared, o, &wrong));
  for (const auto& p : wrong.pairs) {
    // Nothing says which of the two is wrong: both are withdrawn.
    EXPECT_FALSE(p.accepted) << p.graph_id;
    EXPECT_TRUE(p.contradicted) << p.graph_id;
    EXPECT_EQ(p.candidates[0].status, CandidateStatus::kContradicted);
    EXPECT_NE(p.reason.find("are of floor 2"), std::string::npos) << p.reason;
  }
  FloorMatcherOptions off = o;
  off.same_floor_see_through = 1.0;
  MatchResult unchecked = passPlacingB(Pose2(-18.0, 0.0, 0.0) * frame_b);
  EXPECT_FALSE(rejectContradictedPlacements(graphs, prepared, off, &unchecked));
}

TEST(ParticleFilter, WallModelLowersExactlyTheParticlesWhoseBeamsCrossWalls) {
  const auto g = driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 3);
  const LocalizationMap map(floor::renderFloorMap(g, {}), {});
  const WallModel walls = makeWallModel(map.frame(), solidWalls(map.field(), g, 90));
  ParticleFilterOptions o;
  o.initial_particles_per_m2 = 5.0;
  ParticleFilter plain(map, o, 21), with_walls(map, o, 21);
  const int traced = 12;
  const double log_p = -10.0, margin = 0.3;
  with_walls.setWallModel(&walls, traced, log_p, margin);
  plain.initializeUniform();
  with_walls.initializeUniform();
  const sensor::LaserScan& scan = g.nodes[7].scan;
  plain.update(scan);
  with_walls.update(scan);
  ASSERT_EQ(plain.size(), with_walls.size());
  // Per particle: log(w_walls / w_plain) = constant + effective_beams * log_p * (fraction
  // of the traced beams crossing a wall).
  const std::vector<Eigen::Vector2d> beams = selectBeams(scan, traced);
  double offset = std::numeric_limits<double>::quiet_NaN();
  int crossing_particles = 0, checked = 0;
  for (std::size_t j = 0; j < plain.size(); ++j) {
    const double wp = plain.weights()[j], ww = with_walls.weights()[j];
    const Pose2 pose(plain.xs()[j], plain.ys()[j], plain.thetas()[j]);
    const Eigen::Vector2d origin = pose.transformPoint(scan.sensor_offset.translation());
    int crossed = 0;
    for (const auto& b : beams) {
      const Eigen::Vector2d d = b - scan.sensor_offset.translation();
      const Eigen::Vector2d stop =
          scan.sensor_offset.translation() + d * ((d.norm() - margin) / d.norm());
      crossed += walls.crosses(origin, pose.transformPoint(stop));
    }
    crossing_particles += crossed > 0;
    if (wp < 1e-250 || ww < 1e-250) continue;
    const double expected = o.effective_beams * log_p * crossed / static_cast<double>(beams.size());
    const double ratio = std::log(ww / wp) - expected;
    if (std::isnan(offset)) offset = ratio;
    EXPECT_NEAR(ratio, offset, 1e-6) << "particle " << j << " crossed " << crossed;
    ++checked;
  }
  EXPECT_GT(crossing_particles, 0);
  EXPECT_GT(checked, 10);
}

// A constraint claims 1/sigma_xy^2 across the direction its scans pin best and ratio
// times that along the weak one; without a ratio it is isotropic as before.
TEST(FloorMatcher, ConstraintInformationIsWeakAlongTheUnpinnedDirection) {
  FloorMatcherOptions o;
  o.constraint_sigma_xy = 0.05;
  o.constraint_sigma_theta = 0.01;
  Candidate c;
  c.information_ratio = 0.04;
  c.weak_direction = M_PI / 2;  // along y in the reference node's frame
  const Eigen::Matrix3d info = constraintInformation(c, o);
  EXPECT_NEAR(info(0, 0), 400.0, 1e-9);
  EXPECT_NEAR(info(1, 1), 16.0, 1e-9);  // sigma 0.25 m along y
  EXPECT_NEAR(info(0, 1), 0.0, 1e-9);
  EXPECT_NEAR(info(2, 2), 1e4, 1e-6);
  c.weak_direction = M_PI / 4;  // the same, turned: eigenvalues kept
  const Eigen::Matrix2d turned = constraintInformation(c, o).topLeftCorner(2, 2);
  EXPECT_NEAR(turned.trace(), 416.0, 1e-9);
  EXPECT_NEAR(turned.determinant(), 400.0 * 16.0, 1e-6);
  c.information_ratio = 0.0;  // never singular
  const Eigen::Matrix2d floor_only = constraintInformation(c, o).topLeftCorner(2, 2);
  EXPECT_GT(floor_only.determinant(), 0.0);
  c.information_ratio = -1.0;  // not computed
  EXPECT_NEAR(constraintInformation(c, o)(1, 1), 400.0, 1e-9);
}

// The joint alignment of a set fitted in both directions: weighted means of translation
// and heading. Two alignments that agree where the scans lie (here 41 m from the floor's
// origin) and differ by 0.01 rad keep that place within a millimetre.
TEST(FloorMatcher, CombinedAlignmentsAreWeightedMeansThatKeepWhereTheyAgree) {
  const Eigen::Vector2d centre(40.0, 10.0);
  const geometry::Pose2 a(3.0, -2.0, 0.50);
  const geometry::Pose2 same = combineAlignments(a, 5, a, 2);
  EXPECT_NEAR(same.x(), a.x(), 1e-12);
  EXPECT_NEAR(same.y(), a.y(), 1e-12);
  EXPECT_NEAR(same.theta(), a.theta(), 1e-12);
  // b: a turned by 0.01 rad about where a puts the centre, then moved 0.03 m along x.
  const Eigen::Vector2d at = a.transformPoint(centre);
  const geometry::Pose2 b = geometry::Pose2(0.03, 0.0, 0.0) * geometry::Pose2(at.x(), at.y(), 0.01) *
                            geometry::Pose2(-at.x(), -at.y(), 0.0) * a;
  const geometry::Pose2 ab = combineAlignments(a, 3, b, 1);
  EXPECT_NEAR(ab.theta(), 0.50 + 0.01 / 4.0, 1e-6);
  EXPECT_NEAR(ab.x(), (3 * a.x() + b.x()) / 4, 1e-12);
  const Eigen::Vector2d placed = ab.transformPoint(centre);
  EXPECT_NEAR(placed.x(), at.x() + 0.03 / 4.0, 1e-3);
  EXPECT_NEAR(placed.y(), at.y(), 1e-3);
  // Reversed weights: the heading moves to b's side.
  EXPECT_NEAR(combineAlignments(a, 1, b, 3).theta(), 0.50 + 0.03 / 4.0, 1e-6);
}

// Three office floors for the path through an aligned graph: C (graph 2) is matched
// against the reference A (graph 0) and against B (graph 1), whose alignment into A's
// frame is known. The candidates are made by hand (no filter runs), so the test is about
// what combineThroughAligned does with them.
struct ThreeFloors {
  Pose2 frame_b{1.3, -0.7, 0.3};   // B's graph frame in A's
  Pose2 frame_c{-0.8, 0.5, -0.2};  // C's graph frame in A's: the alignment sought
  std::vector<floor::FloorGraph> graphs;
  FloorMatcherOptions options = fastOptions();
  std::vector<PreparedFloor> prepared;

  ThreeFloors() {
    graphs = {driveFloor(officeFloor(0), officePath(0), Pose2(), 0, 0.0, 8),
              driveFloor(officeFloor(1), officePath(1), frame_b, 1, 3.2, 9),
              driveFloor(officeFloor(1), officePath(0), frame_c, 2, 6.4, 10)};
    for (const auto& g : graphs) prepared.push_back(prepareFloor(g, options));
  }
  const floor::FloorGraph& c() const { return graphs[2]; }
  Pose2 cInB() const { return frame_b.inverse() * frame_c; }

  // A candidate that passed the gate and was too few alone: C's nodes [first, first + 4]
  // localised in `map`'s map at `alignment` (C's frame into map's), or, reversed, map's
  // nodes [first, first + 4] localised in C's map (alignment still C's frame into map's).
  Candidate gated(const floor::FloorGraph& map, int first, const Pose2& alignment, bool reversed) const {
    const floor::FloorGraph& g = c();
    Candidate k;
    k.reference_graph_id = map.graph_id;
    k.graph_id = g.graph_id;
    k.first_index = first;
    k.last_index = first + 4;
    k.reversed = reversed;
    k.alignment = alignment;
    k.likelihood = 1.0;
    k.status = CandidateStatus::kTooFew;
    int q = 0, node_k = 0;  // map's node, C's node
    if (reversed) {
      q = first;
      node_k = g.nearestNodeIndex((alignment.inverse() * map.nodes[q].pose).translation());
    } else {
      node_k = first;
      q = map.nearestNodeIndex((alignment * g.nodes[node_k].pose).translation());
    }
    k.node_index = node_k;
    k.node_id = g.nodes[node_k].id;
    k.reference_node_id = map.nodes[q].id;
    k.measurement = map.nodes[q].pose.between(alignment * g.nodes[node_k].pose);
    return k;
  }
  PairResult pair(int reference_graph_id, std::vector<Candidate> candidates) const {
    PairResult p;
    p.reference_graph_id = reference_graph_id;
    p.graph_id = 2;
    p.candidates = std::move(candidates);
    return p;
  }
  PairResult combine(const PairResult& direct, const PairResult& via) const {
    return combineThroughAligned(direct, via, frame_b, prepared[0], prepared[1], prepared[2], options, 5);
  }
  // Translation error of an alignment of C where C's nodes lie (their centroid), and heading error.
  std::pair<double, double> errors(const Pose2& alignment) const {
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (const auto& n : c().nodes) centroid += n.pose.translation();
    centroid /= static_cast<double>(c().nodes.size());
    return {(alignment.transformPoint(centroid) - frame_c.transformPoint(centroid)).norm(),
            angleError(alignment, frame_c)};
  }
};

// Two candidates against the reference (A's scans in C's map) and two against the aligned
// graph (C's scans in B's map), all 0.7 degrees and 6 cm off: together enough, and the
// joint alignment is refined on all four's scans, each in the map it was localised in.
// Refined on the reference's forward scans alone, as before, there were none here, and
// the candidates' mean stood.
TEST(FloorMatcher, EvidenceThroughAnAlignedFloorIsRefinedOnEveryInliersScans) {
  ThreeFloors f;
  const Pose2 off(0.06, -0.04, 0.012);
  const PairResult direct = f.pair(0, {f.gated(f.graphs[0], 10, f.frame_c * off, true),
                                       f.gated(f.graphs[0], 60, f.frame_c * off, true)});
  const PairResult via = f.pair(1, {f.gated(f.graphs[1], 20, f.cInB() * off, false),
                                    f.gated(f.graphs[1], 70, f.cInB() * off, false)});
  const PairResult both = f.combine(direct, via);
  ASSERT_TRUE(both.accepted) << both.reason;
  int accepted = 0;
  for (const auto& k : both.candidates) accepted += k.status == CandidateStatus::kAccepted;
  EXPECT_EQ(accepted, 4);
  const auto [metres, radians] = f.errors(both.alignment);
  EXPECT_LT(metres, 0.02);
  EXPECT_LT(radians, 0.002);

  f.options.joint_alignment_both_directions = false;  // the mean stands: as far off as the candidates
  const PairResult forward_only = f.combine(direct, via);
  ASSERT_TRUE(forward_only.accepted);
  EXPECT_NEAR(f.errors(forward_only.alignment).second, 0.012, 1e-6);
}

// Four candidates at the true alignment against a second consistent set 2 m along the
// corridor: the rival rule of a direct pair, the whole floor fitted in both maps. Three
// rivals fit it worse (the larger set wins); five outnumber the truth, and the floor is
// ambiguous rather than placed by the larger, wrong set.
TEST(FloorMatcher, ARivalSetThroughAnAlignedFloorIsJudgedByTheWholeFloorsFit) {
  const ThreeFloors f;
  const Pose2 shifted_in_a = Pose2(2.0, 0.0, 0.0) * f.frame_c;
  const Pose2 shifted_in_b = f.frame_b.inverse() * shifted_in_a;
  const PairResult direct = f.pair(0, {f.gated(f.graphs[0], 0, f.frame_c, false),
                                       f.gated(f.graphs[0], 30, f.frame_c, false)});
  std::vector<Candidate> via_candidates{f.gated(f.graphs[1], 60, f.cInB(), false),
                                        f.gated(f.graphs[1], 90, f.cInB(), false)};
  for (int first : {10, 40, 75}) via_candidates.push_back(f.gated(f.graphs[1], first, shifted_in_b, false));
  const PairResult three = f.combine(direct, f.pair(1, via_candidates));
  ASSERT_TRUE(three.accepted) << three.reason;
  for (std::size_t i = 0; i < three.candidates.size(); ++i) {
    const bool right = i < 4;  // the two direct ones, then the via pair's first two
    EXPECT_EQ(three.candidates[i].status == CandidateStatus::kAccepted, right) << i << ": " << three.reason;
  }
  EXPECT_LT(f.errors(three.alignment).first, 0.05);

  for (int first : {50, 100}) via_candidates.push_back(f.gated(f.graphs[1], first, shifted_in_b, false));
  const PairResult five = f.combine(direct, f.pair(1, via_candidates));
  EXPECT_FALSE(five.accepted) << five.reason;
  EXPECT_TRUE(five.ambiguous) << five.reason;
  for (const auto& k : five.candidates) EXPECT_NE(k.status, CandidateStatus::kAccepted);
}

// Two floors that share only a lift and the 2 m x 4 m corridor before it (glass3's
// shape): everything else differs, so most of the second floor's scan points find no wall
// of the first's.
test::Walls liftLobbyFloor(int variant) {
  test::Walls w;
  test::addWall(&w, 11, 3, 11, 9);    // corridor and cabin, west
  test::addWall(&w, 13, 3, 13, 9);    // east
  test::addWall(&w, 11, 9, 13, 9);    // the cabin's back
  test::addWall(&w, 11, 7, 11.5, 7);  // the cabin's front, a 1 m door
  test::addWall(&w, 12.5, 7, 13, 7);
  if (variant == 0) {
    test::addBox(&w, 0, -8, 24, 16);
    test::addWall(&w, 0, 3, 8, 3);
    test::addWall(&w, 16, 3, 24, 3);
    test::addWall(&w, 6, -8, 6, -3);
    test::addBox(&w, 2.5, 9.5, 3.5, 10.5);
  } else {
    test::addBox(&w, 2, -6, 22, 13);
    test::addWall(&w, 2, 0, 9, 0);
    test::addWall(&w, 17, -6, 17, 0);
    test::addBox(&w, 18, 4.6, 20, 5.4);
    test::addBox(&w, 6.5, -3.3, 9.5, -2.7);
  }
  return w;
}

// The joint alignment of a set whose inliers all lie in the lobby, started 0.6 degrees and
// 6 cm off: the whole floor's points mostly miss the reference's walls, so they cannot
// refine it, and the inliers' own points do.
TEST(FloorMatcher, AJointAlignmentOfFloorsThatShareOnlyALobbyIsRefinedOnTheLobbysPoints) {
  const Pose2 frame(-0.8, 0.5, -0.2);  // the second graph's frame in the first's: sought
  const auto first =
      driveFloor(liftLobbyFloor(0), {{4, -4}, {4, 1}, {12, 1}, {12, 8.2}}, Pose2(), 0, 0.0, 11);
  const auto second =
      driveFloor(liftLobbyFloor(1), {{12, 8.2}, {12, 2}, {4, 2}, {4, 10}, {4, 2}, {15, -3}}, frame,
                 1, 4.0, 12);
  FloorMatcherOptions o = fastOptions();
  const PreparedFloor reference = prepareFloor(first, o);
  int lobby_end = 0;  // the second floor's nodes in the cabin and the corridor
  while ((frame * second.nodes[lobby_end + 1].pose).y() > 3.0) ++lobby_end;
  ASSERT_GE(lobby_end, 10);
  const std::vector<std::pair<int, int>> lobby{{0, lobby_end}};
  const Pose2 start = frame * Pose2(0.06, -0.03, 0.0105);
  Pose2 on_field = start;
  refineAlignment(reference.map->field(), second, lobby, o.refine_beams, o.refine_iterations,
                  &on_field);
  const Pose2 refined = refinedOnScans(reference, second, lobby, o, start);
  // Errors where the floors meet (the corridor's middle, in the first floor's frame).
  const Eigen::Vector2d lobby_middle(12.0, 5.0);
  auto metres = [&](const Pose2& a) {
    return (a.transformPoint(frame.inverse().transformPoint(lobby_middle)) - lobby_middle).norm();
  };
  EXPECT_LT(metres(refined), 0.01);
  EXPECT_LT(angleError(refined, frame), 0.025 * M_PI / 180);
  // The likelihood field alone leaves it further off, and the whole floor's points are no help.
  EXPECT_GT(angleError(on_field, frame), 2.0 * angleError(refined, frame));
  const std::vector<Eigen::Vector2d> whole =
      floor::floorPoints(second, 0, second.nodes.size(), o.map.max_insert_range);
  grid::PointAlignmentOptions whole_fit;
  whole_fit.max_correspondence_distance = o.point_correspondence_distance;
  whole_fit.robust_distance = o.point_robust_distance;
  EXPECT_LT(grid::alignToPoints(reference.points, whole, on_field, whole_fit).weight_sum,
            0.5 * static_cast<double>(whole.size()));
}

// Three candidates 0.8 degrees off form the set; a fourth, far along the floor, joins
// through the distortion allowance (0.35 m off, within 0.3 m + 2 % of 12 m, and turned 3.4
// degrees, within the 2.9 degrees' rotation tolerance of the set's mean). The joint alignment,
// refined on the scans, is right, and the fourth keeps its own translation, where the floor is, but
// not its heading: the allowance is for a floor stretched, not turned.
TEST(FloorMatcher, ACandidateJoinedThroughTheDistortionAllowanceTakesTheJointsHeading) {
  const ThreeFloors f;  // A (the reference) and C, whose frame in A's is sought
  const floor::FloorGraph& first = f.graphs[0];
  const floor::FloorGraph& second = f.c();
  const Pose2 frame = f.frame_c;
  FloorMatcherOptions o = f.options;
  o.ransac_distortion = 0.02;
  // A gated candidate of `second`'s nodes [k, k + 4] whose alignment places node k at `placed`.
  auto candidate = [&](int k, const Pose2& placed) {
    Candidate c = f.gated(first, k, placed * second.nodes[k].pose.inverse(), false);
    c.status = CandidateStatus::kOutlier;
    return c;
  };
  PairResult pair;
  pair.reference_graph_id = first.graph_id;
  pair.graph_id = second.graph_id;
  for (int k : {0, 6, 12})
    pair.candidates.push_back(candidate(k, frame * second.nodes[k].pose * Pose2(0, 0, 0.014)));
  int far = 13;  // the first node 12 m or more from the set's nodes
  auto from_set = [&](int n) {
    double d = 1e9;
    for (int k : {0, 6, 12})
      d = std::min(
          d, (second.nodes[n].pose.translation() - second.nodes[k].pose.translation()).norm());
    return d;
  };
  while (from_set(far) < 12.0) ++far;
  ASSERT_LT(far + 4, static_cast<int>(second.nodes.size()));
  const Pose2 far_truth = frame * second.nodes[far].pose;
  const Pose2 far_placed(far_truth.x() + 0.35, far_truth.y(), far_truth.theta() + 0.059);
  pair.candidates.push_back(candidate(far, far_placed));
  std::mt19937_64 rng(5);
  decideConsistentSet(f.prepared[0], f.prepared[2], o, &rng, &pair);
  ASSERT_TRUE(pair.accepted) << pair.reason;
  for (const auto& c : pair.candidates)
    EXPECT_EQ(c.status, CandidateStatus::kAccepted) << c.first_index << ": " << c.reason;
  EXPECT_LT(angleError(pair.alignment, frame), 0.2 * M_PI / 180);
  const Candidate& joined = pair.candidates.back();
  const Pose2 measured = first.findNode(joined.reference_node_id)->pose * joined.measurement;
  EXPECT_NEAR((measured.translation() - far_placed.translation()).norm(), 0.0, 1e-9);  // its own
  EXPECT_LT(std::abs(geometry::angleDiff(measured.theta(), far_truth.theta())), 0.2 * M_PI / 180);
}

// A robot drives graph 0 east to (9, 0), rides a lift that leaves it where it entered with
// its odometry turned 2 degrees, and starts graph 1 (its own frame: the first node at the
// origin). A placement of graph 1 that keeps the ride together is not contradicted; one
// turned about the lift by 90 degrees, or 20 m away, is, and the reason names the nodes.
TEST(FloorMatcher, APlacementIsCheckedAgainstTheRobotsFloorChanges) {
  std::vector<floor::FloorGraph> graphs(2);
  for (int g = 0; g < 2; ++g) {
    graphs[g].graph_id = g;
    graphs[g].floor_id = g;
    graphs[g].robot = "r";
    for (int i = 0; i < 10; ++i) {
      floor::FloorNode n;
      n.id = i;
      n.stamp = 10.0 * g + i;
      n.pose = Pose2(static_cast<double>(i), 0.0, 0.0);
      // Odometry runs on through the ride, 2 degrees of slip in the cabin.
      n.odometry = g == 0 ? n.pose : Pose2(9.0, 0.0, 0.035) * n.pose;
      graphs[g].nodes.push_back(n);
    }
  }
  const auto links = floor::transitLinks(graphs);
  ASSERT_EQ(links.size(), 1u);
  FloorMatcherOptions o;
  o.floor_change = {15.0, 0.35};
  const std::map<int, Pose2> placed{{0, Pose2()}};
  const Pose2 kept_together(9.0, 0.0, 0.0);
  EXPECT_EQ(floorChangeContradiction(graphs, links, 1, kept_together, placed, o), "");
  const std::string turned =
      floorChangeContradiction(graphs, links, 1, Pose2(9.0, 0.0, M_PI / 2), placed, o);
  EXPECT_NE(turned.find("floor change from graph 0 (node 9) to graph 1 (node 0)"),
            std::string::npos)
      << turned;
  EXPECT_NE(turned.find("deg from the robot's odometry"), std::string::npos) << turned;
  const std::string far =
      floorChangeContradiction(graphs, links, 1, Pose2(29.0, 0.0, 0.0), placed, o);
  EXPECT_NE(far.find("m apart"), std::string::npos) << far;
  // Seen from the other side: graph 0 placed against a placed graph 1.
  EXPECT_NE(
      floorChangeContradiction(graphs, links, 0, Pose2(0, 0, -M_PI / 2), {{1, kept_together}}, o),
      "");
  // Not judged: the other graph not placed, or the check off.
  EXPECT_EQ(floorChangeContradiction(graphs, links, 1, Pose2(9.0, 0.0, M_PI / 2), {}, o), "");
  o.floor_change = {};
  EXPECT_EQ(floorChangeContradiction(graphs, links, 1, Pose2(29.0, 0.0, M_PI / 2), placed, o), "");
}

TEST(ConstraintJudgement, AnErrorAlongAClaimedWeakDirectionIsNotWrongAcrossItIs) {
  FloorMatcherOptions o;
  Candidate c;
  c.information_ratio = 0.01;   // sigma 0.5 m along the weak direction
  c.weak_direction = M_PI / 2;  // y in the reference node's frame
  const Eigen::Matrix3d corridor = constraintInformation(c, o);
  const Pose2 truth(2.0, 1.0, 0.3);
  // 0.9 m along y: within 3 x 0.5 m, off by the fixed limit only.
  ConstraintJudgement j = judgeConstraint(Pose2(2.0, 1.9, 0.3), truth, corridor);
  EXPECT_NEAR(j.translation, 0.9, 1e-12);
  EXPECT_NEAR(j.along_weak, 0.9, 1e-12);
  EXPECT_NEAR(j.across_weak, 0.0, 1e-12);
  EXPECT_NEAR(j.weak_sigma, 0.5, 1e-9);
  EXPECT_TRUE(j.off);
  EXPECT_FALSE(j.wrong);
  // 1.6 m along it: beyond 3 claimed sigmas.
  EXPECT_TRUE(judgeConstraint(Pose2(2.0, 2.6, 0.3), truth, corridor).wrong);
  // 0.35 m across it: the constraint claims 0.05 m there.
  j = judgeConstraint(Pose2(2.35, 1.0, 0.3), truth, corridor);
  EXPECT_NEAR(j.across_weak, 0.35, 1e-12);
  EXPECT_TRUE(j.wrong);
  // Both: 0.25 m across and 1.2 m along (0.24 of the 1.5 m limit, scaled to 0.3 m) is
  // over the limit together though each part is under it.
  EXPECT_TRUE(judgeConstraint(Pose2(2.25, 2.2, 0.3), truth, corridor).wrong);
  EXPECT_FALSE(judgeConstraint(Pose2(2.1, 2.2, 0.3), truth, corridor).wrong);
  // Heading: 2 degrees whatever the translation claims.
  EXPECT_TRUE(judgeConstraint(Pose2(2.0, 1.0, 0.3 + 0.04), truth, corridor).wrong);
  // An isotropic claim is judged by the fixed limits alone: 0.29 m is right, 0.31 wrong,
  // in any direction.
  c.information_ratio = -1.0;
  const Eigen::Matrix3d room = constraintInformation(c, o);
  for (double angle : {0.0, 1.0, 2.5}) {
    const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
    const auto at = [&](double m) { return Pose2(2.0 + m * d.x(), 1.0 + m * d.y(), 0.3); };
    EXPECT_FALSE(judgeConstraint(at(0.29), truth, room).wrong) << angle;
    EXPECT_TRUE(judgeConstraint(at(0.31), truth, room).wrong) << angle;
    EXPECT_TRUE(judgeConstraint(at(0.31), truth, room).off) << angle;
  }
}

// A mapped graph's node poses are estimates, bent against the truth: a constraint is
// judged by the true poses of its own two nodes, not through a rigid frame of the graph.
TEST(ConstraintJudgement, MappedGraphsAreJudgedByTheirNodesTruePoses) {
  SimulatedFloors floors;
  floors.graphs.resize(2);
  floors.frames = {Pose2(), Pose2()};
  for (int g = 0; g < 2; ++g) {
    floors.graphs[g].graph_id = g;
    for (int i = 0; i < 2; ++i) {
      floor::FloorNode n;
      n.id = 10 * g + i;
      n.pose = Pose2(40.0 * i, 0.0, 0.0);  // as mapped: 40 m apart
      floors.graphs[g].nodes.push_back(n);
    }
  }
  InterFloorConstraint c;
  c.reference_graph_id = 0;
  c.reference_node_id = 1;
  c.graph_id = 1;
  c.node_id = 11;
  c.measurement = Pose2(0.5, 0.0, 0.0);  // graph 1's node 11 lies 0.5 m past graph 0's node 1
  c.information = Eigen::Matrix3d::Identity() * 400.0;
  // Without node truths the graphs are taken as true: 0.5 m off, wrong.
  EXPECT_NEAR(judgeConstraint(c, floors).translation, 0.5, 1e-12);
  EXPECT_TRUE(judgeConstraint(c, floors).wrong);
  // In truth graph 1 is 1.25 % longer than mapped (its node 11 at 40.5 m): right.
  floors.node_truth = {{{0, Pose2(0, 0, 0)}, {1, Pose2(40, 0, 0)}}, {{10, Pose2(0, 0, 0)}, {11, Pose2(40.5, 0, 0)}}};
  EXPECT_NEAR(judgeConstraint(c, floors).translation, 0.0, 1e-12);
  EXPECT_FALSE(judgeConstraint(c, floors).wrong);
  // A node without a truth falls back to its graph's frame.
  floors.node_truth[1].erase(11);
  EXPECT_NEAR(judgeConstraint(c, floors).translation, 0.5, 1e-12);
}

TEST(FloorMatcherOptions, ReadsValuesAndRejectsUnknownKeys) {
  const auto node = common::ConfigNode::loadString(
      "min_sequence: 4\nseed: 9\nfilter:\n  beams: 30\n  motion:\n    rot_rot: 0.2\n");
  const FloorMatcherOptions o = readFloorMatcherOptions(node);
  EXPECT_EQ(o.min_sequence, 4);
  EXPECT_EQ(o.seed, 9u);
  EXPECT_EQ(o.filter.beams, 30);
  EXPECT_DOUBLE_EQ(o.filter.motion.rot_rot, 0.2);
  EXPECT_THROW(readFloorMatcherOptions(common::ConfigNode::loadString("min_sequense: 4\n")),
               common::ConfigError);
  EXPECT_THROW(readFloorMatcherOptions(common::ConfigNode::loadString("filter: {beams: 0}\n")),
               common::ConfigError);
  const FloorMatcherOptions changes = readFloorMatcherOptions(
      common::ConfigNode::loadString("floor_change_radius: 12\nfloor_change_heading: 0.3\n"));
  EXPECT_DOUBLE_EQ(changes.floor_change.radius, 12.0);
  EXPECT_DOUBLE_EQ(changes.floor_change.heading, 0.3);
  EXPECT_THROW(readFloorMatcherOptions(common::ConfigNode::loadString("floor_change_heading: 4\n")),
               common::ConfigError);
}

TEST(FloorMatcherOptions, ShippedConfigLoads) {
  const auto node =
      common::ConfigNode::loadFile(storey::test::sourceDir() + "/config/floor_matcher.yaml");
  const FloorMatcherOptions o = readFloorMatcherOptions(node.child("floor_matcher"));
  // The component's growth passes hold back placements by these limits too (retraction.h).
  EXPECT_DOUBLE_EQ(o.floor_change.radius, 15.0);
  EXPECT_DOUBLE_EQ(o.floor_change.heading, 0.35);
  EXPECT_NO_THROW(readRetractionOptions(node.child("retraction")));
}

}  // namespace
}  // namespace storey::matching
