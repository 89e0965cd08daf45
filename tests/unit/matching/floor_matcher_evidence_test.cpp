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
#include "storey/matching/floor_matcher.h"
#include "storey/matching/retraction.h"
#include "synthetic_floor.h"
#include "test_support.h"

namespace storey::matching {
namespace {

using geometry::Pose2;
using test::angleError;
using test::driveFloor;
using test::fastOptions;
using test::officeFloor;
using test::officePath;

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
  const geometry::Pose2 b = geometry::Pose2(0.03, 0.0, 0.0) *
                            geometry::Pose2(at.x(), at.y(), 0.01) *
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
  Candidate gated(const floor::FloorGraph& map, int first, const Pose2& alignment,
                  bool reversed) const {
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
    return combineThroughAligned(direct, via, frame_b, prepared[0], prepared[1], prepared[2],
                                 options, 5);
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

  f.options.joint_alignment_both_directions =
      false;  // the mean stands: as far off as the candidates
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
  const PairResult direct = f.pair(
      0, {f.gated(f.graphs[0], 0, f.frame_c, false), f.gated(f.graphs[0], 30, f.frame_c, false)});
  std::vector<Candidate> via_candidates{f.gated(f.graphs[1], 60, f.cInB(), false),
                                        f.gated(f.graphs[1], 90, f.cInB(), false)};
  for (int first : {10, 40, 75})
    via_candidates.push_back(f.gated(f.graphs[1], first, shifted_in_b, false));
  const PairResult three = f.combine(direct, f.pair(1, via_candidates));
  ASSERT_TRUE(three.accepted) << three.reason;
  for (std::size_t i = 0; i < three.candidates.size(); ++i) {
    const bool right = i < 4;  // the two direct ones, then the via pair's first two
    EXPECT_EQ(three.candidates[i].status == CandidateStatus::kAccepted, right)
        << i << ": " << three.reason;
  }
  EXPECT_LT(f.errors(three.alignment).first, 0.05);

  for (int first : {50, 100})
    via_candidates.push_back(f.gated(f.graphs[1], first, shifted_in_b, false));
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
}  // namespace
}  // namespace storey::matching
