// Which published constraints a new matching pass retracts (storey::matching::constraintsToRetract).
#include "storey/matching/retraction.h"

#include <gtest/gtest.h>

#include <cmath>
#include <tuple>

#include "storey/common/config.h"

namespace storey::matching {
namespace {

using geometry::Pose2;

// A graph of `count` nodes along x, 1 m apart, in its own frame.
floor::FloorGraph lineGraph(int id, int count) {
  floor::FloorGraph g;
  g.graph_id = id;
  g.floor_id = id;
  for (int i = 0; i < count; ++i) {
    floor::FloorNode n;
    n.id = i;
    n.pose = Pose2(i, 0.0, 0.0);
    g.nodes.push_back(n);
  }
  return g;
}

// The constraint that places `graph`'s node `node` by alignment `t` (graph frame in the
// reference's frame), against the reference's node `reference_node`.
InterFloorConstraint constraintFrom(const floor::FloorGraph& reference, int reference_node,
                                    const floor::FloorGraph& graph, int node, const Pose2& t) {
  InterFloorConstraint c;
  c.reference_graph_id = reference.graph_id;
  c.reference_node_id = reference_node;
  c.graph_id = graph.graph_id;
  c.node_id = node;
  c.measurement = reference.findNode(reference_node)->pose.between(t * graph.findNode(node)->pose);
  // A room's constraint: 5 cm and 0.6 deg either way.
  c.information = Eigen::Vector3d(400.0, 400.0, 10000.0).asDiagonal();
  return c;
}

// The same, claiming to know little along the x axis of the reference node's frame (a
// corridor's length): sigma `along` there.
InterFloorConstraint corridorConstraintFrom(const floor::FloorGraph& reference, int reference_node,
                                            const floor::FloorGraph& graph, int node, const Pose2& t,
                                            double along) {
  InterFloorConstraint c = constraintFrom(reference, reference_node, graph, node, t);
  c.information(0, 0) = 1.0 / (along * along);
  return c;
}

struct Building {
  std::vector<floor::FloorGraph> graphs{lineGraph(0, 10), lineGraph(1, 10), lineGraph(2, 10)};
  Pose2 truth1{0.5, -0.2, 0.1};
  Pose2 truth2{-1.0, 0.3, -0.05};
};

MatchResult passAligning(const Building& b, const Pose2& t1) {
  MatchResult r;
  r.reference_graph_id = 0;
  for (int k : {2, 5, 8}) r.constraints.push_back(constraintFrom(b.graphs[0], k, b.graphs[1], k, t1));
  PairResult p;
  p.reference_graph_id = 0;
  p.graph_id = 1;
  p.accepted = true;
  p.alignment = t1;
  r.pairs.push_back(p);
  return r;
}

TEST(ConstraintRetraction, ConstraintsTheNewPassConfirmsStand) {
  const Building b;
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[0], 1, b.graphs[1], 3, b.truth1)};
  // The new pass found the same alignment through other nodes, a little differently.
  const Pose2 again = Pose2(0.02, 0.01, 0.002) * b.truth1;
  EXPECT_TRUE(constraintsToRetract(published, b.graphs, passAligning(b, again), {}).empty());
}

TEST(ConstraintRetraction, AConstraintTheNewPassPlacesElsewhereIsRetracted) {
  const Building b;
  // Published when graph 1 looked like it lay 3 m further along (a repeated room).
  const Pose2 wrong = Pose2(3.0, 0.0, 0.0) * b.truth1;
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[0], 4, b.graphs[1], 1, wrong),
                                                    constraintFrom(b.graphs[0], 7, b.graphs[1], 6, b.truth1)};
  const auto retract = constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), {});
  ASSERT_EQ(retract.size(), 1u);
  EXPECT_EQ(retract[0].index, 0u);
  EXPECT_NE(retract[0].reason.find("3.00 m"), std::string::npos) << retract[0].reason;
}

TEST(ConstraintRetraction, TheTolerancesAreTheOptions) {
  const Building b;
  const Pose2 off = Pose2(0.0, 0.0, 0.06) * b.truth1;  // 3.4 deg about graph 0's origin
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[0], 0, b.graphs[1], 0, off)};
  RetractionOptions o;
  o.translation = 10.0;
  o.rotation = 0.1;
  EXPECT_TRUE(constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), o).empty());
  o.rotation = 0.05;
  EXPECT_EQ(constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), o).size(), 1u);
  o.enabled = false;
  EXPECT_TRUE(constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), o).empty());
}

TEST(ConstraintRetraction, AlongItsWeakDirectionAConstraintIsHeldToWhatItClaims) {
  const Building b;
  // Reference nodes lie along x with heading 0, so their frames' x is the graph's x.
  // Published where the new pass places graph 1 0.45 m further along x (and 0.45 m
  // across, for the second pair).
  const Pose2 along = Pose2(0.45, 0.0, 0.0) * b.truth1;
  const Pose2 across = Pose2(0.0, 0.45, 0.0) * b.truth1;
  const std::vector<InterFloorConstraint> published{
      corridorConstraintFrom(b.graphs[0], 3, b.graphs[1], 3, along, 0.2),   // 3 sigma: 0.6 m
      corridorConstraintFrom(b.graphs[0], 4, b.graphs[1], 4, across, 0.2),  // across: 0.3 m
      constraintFrom(b.graphs[0], 5, b.graphs[1], 5, along),                // a room's: 0.3 m
      corridorConstraintFrom(b.graphs[0], 6, b.graphs[1], 6, along, 0.1)};  // 3 sigma: 0.3 m
  const auto retract = constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), {});
  ASSERT_EQ(retract.size(), 3u);
  EXPECT_EQ(retract[0].index, 1u);
  EXPECT_EQ(retract[1].index, 2u);
  EXPECT_EQ(retract[2].index, 3u);
  EXPECT_NE(retract[2].reason.find("0.45 along the constraint's weak direction, sigma 0.10"), std::string::npos)
      << retract[2].reason;
  // weak_sigmas 0: the fixed limits in every direction.
  RetractionOptions fixed;
  fixed.weak_sigmas = 0.0;
  EXPECT_EQ(constraintsToRetract(published, b.graphs, passAligning(b, b.truth1), fixed).size(), 4u);
  // The growth pass's confirmation asks the same question of the pass before.
  const GraphPlacement before = placeGraphs(b.graphs, passAligning(b, b.truth1));
  EXPECT_EQ(placementDisagreement(published[0], b.graphs, before, {}), 0);
  EXPECT_EQ(placementDisagreement(published[1], b.graphs, before, {}), 1);
}

TEST(ConstraintRetraction, GraphsPlacedThroughAThirdAreCompared) {
  const Building b;
  // Published: graph 2 against graph 1 directly. The new pass places both against graph 0.
  const Pose2 two_in_one = b.truth1.inverse() * b.truth2;
  const Pose2 wrong_two_in_one = Pose2(0.0, 2.0, 0.0) * two_in_one;
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[1], 4, b.graphs[2], 4, two_in_one),
                                                    constraintFrom(b.graphs[1], 5, b.graphs[2], 5, wrong_two_in_one)};
  MatchResult r = passAligning(b, b.truth1);
  for (int k : {1, 3, 9}) r.constraints.push_back(constraintFrom(b.graphs[0], k, b.graphs[2], k, b.truth2));
  const auto retract = constraintsToRetract(published, b.graphs, r, {});
  ASSERT_EQ(retract.size(), 1u);
  EXPECT_EQ(retract[0].index, 1u);
}

TEST(ConstraintRetraction, AGraphFoundAmbiguousLosesItsConstraints) {
  const Building b;
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[0], 2, b.graphs[2], 2, b.truth2),
                                                    constraintFrom(b.graphs[0], 2, b.graphs[1], 2, b.truth1)};
  MatchResult r = passAligning(b, b.truth1);
  PairResult p;
  p.reference_graph_id = 0;
  p.graph_id = 2;
  p.ambiguous = true;
  r.pairs.push_back(p);
  const auto retract = constraintsToRetract(published, b.graphs, r, {});
  ASSERT_EQ(retract.size(), 1u);
  EXPECT_EQ(retract[0].index, 0u);
  EXPECT_NE(retract[0].reason.find("ambiguous"), std::string::npos) << retract[0].reason;

  // A self-similar floor aligned nowhere, the same.
  MatchResult s = passAligning(b, b.truth1);
  FloorCheck f;
  f.graph_id = 2;
  f.self_similar = true;
  s.floors.push_back(f);
  EXPECT_EQ(constraintsToRetract(published, b.graphs, s, {}).size(), 1u);
}

TEST(ConstraintRetraction, AGraphTheNewPassDoesNotAlignKeepsItsConstraints) {
  const Building b;
  // Graph 2 found too few consistent candidates this time: no evidence against it.
  const std::vector<InterFloorConstraint> published{constraintFrom(b.graphs[0], 2, b.graphs[2], 2, b.truth2)};
  MatchResult r = passAligning(b, b.truth1);
  PairResult p;
  p.reference_graph_id = 0;
  p.graph_id = 2;
  p.reason = "too few";
  r.pairs.push_back(p);
  EXPECT_TRUE(constraintsToRetract(published, b.graphs, r, {}).empty());
  // Nor does a pass that aligned nothing at all.
  EXPECT_TRUE(constraintsToRetract(published, b.graphs, MatchResult{}, {}).empty());
}

// The graphs as they stood with `nodes` nodes each (line graphs, so earlier nodes keep
// their poses).
std::vector<floor::FloorGraph> prefixes(const Building& b, std::size_t nodes) {
  std::vector<floor::FloorGraph> out = b.graphs;
  for (auto& g : out) g.nodes.resize(nodes);
  return out;
}

TEST(PlacementConfirmation, OnlyAPassOnLessOfTheGraphsConfirms) {
  const Building b;
  RetractionOptions o;  // confirm_growth 0.2
  const InterFloorConstraint c = constraintFrom(b.graphs[0], 2, b.graphs[1], 2, b.truth1);
  PlacementHistory history;
  EXPECT_FALSE(history.confirms(c, b.graphs, o)) << "no pass before";
  // A pass on 8 nodes of each graph placed them the way c does.
  const auto eight = prefixes(b, 8);
  history.record(eight, passAligning(b, b.truth1));
  EXPECT_FALSE(history.confirms(c, eight, o)) << "the same graphs seen again are no more evidence";
  EXPECT_FALSE(history.confirms(c, prefixes(b, 9), o)) << "9 nodes: grown by 12.5 %";
  EXPECT_TRUE(history.confirms(c, b.graphs, o)) << "10 nodes: grown by 25 %";
  o.confirm_growth = 0.0;
  EXPECT_TRUE(history.confirms(c, eight, o)) << "growth 0: the pass before confirms";

  // A later pass on 9 nodes placed graph 1 3 m away: the latest pass the growth allows
  // is the one asked, so on 10 nodes the 8-node pass still confirms (25 %), but growth 0
  // asks the 9-node pass, which disagrees.
  history.record(prefixes(b, 9), passAligning(b, Pose2(3.0, 0.0, 0.0) * b.truth1));
  o.confirm_growth = 0.2;
  EXPECT_TRUE(history.confirms(c, b.graphs, o));
  o.confirm_growth = 0.0;
  EXPECT_FALSE(history.confirms(c, b.graphs, o));
  // A pass that did not join the two graphs is passed over.
  history.record(prefixes(b, 10), MatchResult{});
  EXPECT_FALSE(history.confirms(c, b.graphs, o));
  o.confirm_growth = 0.2;
  EXPECT_TRUE(history.confirms(c, b.graphs, o));
  // One graph grown is enough: the reference (a finished floor's graph never grows).
  auto reference_grown = prefixes(b, 8);
  reference_grown[0] = b.graphs[0];
  EXPECT_TRUE(history.confirms(c, reference_grown, o));
  // Nor does a constraint on a graph the pass lacks get confirmed.
  std::vector<floor::FloorGraph> two_only{b.graphs[0], b.graphs[2]};
  EXPECT_FALSE(history.confirms(c, two_only, o));
}

TEST(PlacementConfirmation, BothSidesAskTheAcceptedCandidatesOfTheConstraintsPair) {
  const Building b;
  const InterFloorConstraint c = constraintFrom(b.graphs[0], 2, b.graphs[1], 2, b.truth1);
  MatchResult r = passAligning(b, b.truth1);
  auto candidate = [](bool reversed, CandidateStatus status) {
    Candidate k;
    k.reversed = reversed;
    k.status = status;
    return k;
  };
  PairResult& pair = r.pairs[0];
  pair.candidates = {candidate(false, CandidateStatus::kAccepted), candidate(true, CandidateStatus::kOutlier)};
  EXPECT_FALSE(pairSeenFromBothSides(c, r)) << "the reversed one is an outlier";
  // Another pair's reversed inlier does not count for this one.
  PairResult other;
  other.reference_graph_id = 0;
  other.graph_id = 2;
  other.candidates = {candidate(true, CandidateStatus::kAccepted)};
  r.pairs.push_back(other);
  EXPECT_FALSE(pairSeenFromBothSides(c, r));
  r.pairs[0].candidates.push_back(candidate(true, CandidateStatus::kAccepted));
  EXPECT_TRUE(pairSeenFromBothSides(c, r));

  // The growth pass's confirmation: the history, and both sides when asked for.
  PlacementHistory history;
  history.record(prefixes(b, 8), passAligning(b, b.truth1));
  RetractionOptions o;
  o.confirm_both_sides = true;
  EXPECT_TRUE(GrowthPassConfirmation(b.graphs, r, history, o, {}).confirms(c));
  const auto eight = prefixes(b, 8);
  EXPECT_FALSE(GrowthPassConfirmation(eight, r, history, o, {}).confirms(c)) << "no growth";
  const MatchResult one_side = passAligning(b, b.truth1);
  EXPECT_FALSE(GrowthPassConfirmation(b.graphs, one_side, history, o, {}).confirms(c));
  o.confirm_both_sides = false;
  EXPECT_TRUE(GrowthPassConfirmation(b.graphs, one_side, history, o, {}).confirms(c));
}

// `g` driven by `robot`, its nodes stamped one a second from `first`.
floor::FloorGraph stamped(floor::FloorGraph g, const std::string& robot, double first) {
  g.robot = robot;
  for (std::size_t i = 0; i < g.nodes.size(); ++i) g.nodes[i].stamp = first + static_cast<double>(i);
  return g;
}

TEST(TransitLinks, AreWhereOneRobotsNodesChangeGraph) {
  std::vector<floor::FloorGraph> graphs{stamped(lineGraph(0, 10), "r", 0.0), stamped(lineGraph(1, 10), "r", 10.0),
                                        stamped(lineGraph(2, 10), "s", 5.0)};
  floor::FloorNode back;  // robot r returns to graph 0
  back.id = 10;
  back.stamp = 20.0;
  graphs[0].nodes.push_back(back);
  const auto links = floor::transitLinks(graphs);
  ASSERT_EQ(links.size(), 2u) << "robot s never changed floor; r did twice";
  EXPECT_EQ(std::make_tuple(links[0].from_graph, links[0].from_node, links[0].to_graph, links[0].to_node),
            std::make_tuple(0, 9, 1, 0));
  EXPECT_EQ(std::make_tuple(links[1].from_graph, links[1].from_node, links[1].to_graph, links[1].to_node),
            std::make_tuple(1, 9, 0, 10));
}

// The floor-change limits config/floor_matcher.yaml gives the matcher, which growth passes share.
const FloorChangeLimits kShippedFloorChange{15.0, 0.35};

TEST(PlacementConfirmation, APlacementThatTearsAFloorChangeApartIsHeldBack) {
  Building b;
  b.graphs[0] = stamped(b.graphs[0], "r", 0.0);   // node 9 at (9, 0)...
  b.graphs[1] = stamped(b.graphs[1], "r", 10.0);  // ...then node 0, by truth1 at (0.5, -0.2): 8.5 m on
  b.graphs[2] = stamped(b.graphs[2], "s", 0.0);
  const Pose2 far = Pose2(30.0, 0.0, 0.0) * b.truth1;  // a look-alike 30 m along
  for (const bool is_far : {false, true}) {
    const Pose2 t = is_far ? far : b.truth1;
    const MatchResult pass = passAligning(b, t);
    PlacementHistory history;
    history.record(prefixes(b, 8), pass);  // an earlier pass placed graph 1 the same way
    const InterFloorConstraint c = constraintFrom(b.graphs[0], 2, b.graphs[1], 2, t);
    RetractionOptions o;
    FloorChangeLimits limits = kShippedFloorChange;  // radius 15 m
    const GrowthPassConfirmation confirmation(b.graphs, pass, history, o, limits);
    if (!is_far) {
      EXPECT_TRUE(confirmation.confirms(c));
      EXPECT_TRUE(confirmation.atOddsWithTransits().empty());
      continue;
    }
    EXPECT_FALSE(confirmation.confirms(c)) << "21.5 m apart";
    ASSERT_EQ(confirmation.atOddsWithTransits().count(1), 1u);
    EXPECT_NE(confirmation.atOddsWithTransits().at(1).find("21.5 m apart"), std::string::npos);
    limits.radius = 25.0;
    EXPECT_TRUE(GrowthPassConfirmation(b.graphs, pass, history, o, limits).confirms(c));
    limits.radius = 0.0;  // off
    EXPECT_TRUE(GrowthPassConfirmation(b.graphs, pass, history, o, limits).confirms(c));
  }
}

TEST(PlacementConfirmation,
     APlacementThatTurnsAFloorChangeAgainstOdometryIsHeldBackAndRetractsNothing) {
  Building b;
  b.graphs[0] = stamped(b.graphs[0], "r", 0.0);
  b.graphs[1] = stamped(b.graphs[1], "r", 10.0);
  b.graphs[2] = stamped(b.graphs[2], "s", 0.0);
  // The robot's odometry runs on through the change: graph 0's frame, graph 1 by truth1
  // (no odometry error, so every placement's turn is measured against the truth's).
  for (auto& n : b.graphs[0].nodes) n.odometry = n.pose;
  for (auto& n : b.graphs[1].nodes) n.odometry = b.truth1 * n.pose;
  // Graph 1 turned end for end about the change's last node (9, 0): its first node lands
  // as far from there as the truth's (8.5 m, inside the radius), facing the other way.
  const Pose2 flipped = Pose2(18.0, 0.0, M_PI) * b.truth1;
  for (const bool is_flipped : {false, true}) {
    const Pose2 t = is_flipped ? flipped : b.truth1;
    const MatchResult pass = passAligning(b, t);
    PlacementHistory history;
    history.record(prefixes(b, 8), pass);
    const InterFloorConstraint c = constraintFrom(b.graphs[0], 2, b.graphs[1], 2, t);
    RetractionOptions o;
    FloorChangeLimits limits = kShippedFloorChange;  // radius 15 m, heading 0.35 rad
    const GrowthPassConfirmation confirmation(b.graphs, pass, history, o, limits);
    if (!is_flipped) {
      EXPECT_TRUE(confirmation.confirms(c));
      EXPECT_TRUE(confirmation.mayRetract(c));
      EXPECT_TRUE(confirmation.atOddsWithTransits().empty());
      continue;
    }
    EXPECT_FALSE(confirmation.confirms(c));
    // Nor does the flipped pass withdraw what a pass before it placed right.
    const InterFloorConstraint right = constraintFrom(b.graphs[0], 5, b.graphs[1], 5, b.truth1);
    ASSERT_EQ(constraintsToRetract({right}, b.graphs, pass, o).size(), 1u);
    EXPECT_FALSE(confirmation.mayRetract(right));
    ASSERT_EQ(confirmation.atOddsWithTransits().count(0), 1u);
    EXPECT_NE(
        confirmation.atOddsWithTransits().at(0).find("turned 180.0 deg from the robot's odometry"),
        std::string::npos)
        << confirmation.atOddsWithTransits().at(0);
    limits.heading = 0.0;  // off: the radius alone lets the flip through
    EXPECT_TRUE(GrowthPassConfirmation(b.graphs, pass, history, o, limits).confirms(c));
  }
}

TEST(ConstraintRetraction, OptionsAreReadStrictly) {
  const auto node = common::ConfigNode::loadString(
      "{enabled: false, translation: 0.8, rotation: 0.2, weak_sigmas: 2, confirm_growth: 0.5, "
      "confirm_both_sides: true}",
      "r.yaml");
  const RetractionOptions o = readRetractionOptions(node);
  EXPECT_FALSE(o.enabled);
  EXPECT_DOUBLE_EQ(o.translation, 0.8);
  EXPECT_DOUBLE_EQ(o.rotation, 0.2);
  EXPECT_DOUBLE_EQ(o.weak_sigmas, 2.0);
  EXPECT_DOUBLE_EQ(o.confirm_growth, 0.5);
  EXPECT_TRUE(o.confirm_both_sides);
  // The floor-change limits moved to the matcher's options (one setting for both checks):
  // a file that still sets them here is told where they went, with its line.
  try {
    readRetractionOptions(common::ConfigNode::loadString(
        "{translation: 0.3,\n confirm_transit_radius: 7}", "r.yaml"));
    ADD_FAILURE() << "confirm_transit_radius accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_EQ(e.file(), "r.yaml");
    EXPECT_EQ(e.line(), 2);
    EXPECT_EQ(e.key(), "confirm_transit_radius");
    EXPECT_NE(std::string(e.what()).find("floor_change_radius"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readRetractionOptions(common::ConfigNode::loadString("{confirm_growth: -0.1}", "r.yaml")),
               std::exception);
  EXPECT_THROW(readRetractionOptions(common::ConfigNode::loadString("{weak_sigmas: -1}", "r.yaml")),
               std::exception);
  EXPECT_THROW(readRetractionOptions(common::ConfigNode::loadString("{translaton: 0.8}", "r.yaml")),
               std::exception);
  EXPECT_THROW(readRetractionOptions(common::ConfigNode::loadString("{rotation: 7}", "r.yaml")), std::exception);
}

}  // namespace
}  // namespace storey::matching
