#include "storey/matching/constraint_judgement.h"

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
#include "storey/matching/floor_matcher.h"
#include "storey/matching/retraction.h"
#include "synthetic_floor.h"
#include "test_support.h"

namespace storey::matching {
namespace {

using eval::SimulatedFloors;
using geometry::Pose2;

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
  floors.node_truth = {{{0, Pose2(0, 0, 0)}, {1, Pose2(40, 0, 0)}},
                       {{10, Pose2(0, 0, 0)}, {11, Pose2(40.5, 0, 0)}}};
  EXPECT_NEAR(judgeConstraint(c, floors).translation, 0.0, 1e-12);
  EXPECT_FALSE(judgeConstraint(c, floors).wrong);
  // A node without a truth falls back to its graph's frame.
  floors.node_truth[1].erase(11);
  EXPECT_NEAR(judgeConstraint(c, floors).translation, 0.5, 1e-12);
}

TEST(FloorMatcherOptions, ReadsValuesAndRejectsUnknownKeys) {
  const auto node =
      common::ConfigNode::loadString("min_sequence: 4\nseed: 9\nfilter:\n  beams: 30\n");
  const FloorMatcherOptions o = readFloorMatcherOptions(node);
  EXPECT_EQ(o.min_sequence, 4);
  EXPECT_EQ(o.seed, 9u);
  EXPECT_EQ(o.filter.beams, 30);
  // A key absent from a section keeps the shipped value, not the filter's own default.
  EXPECT_EQ(o.filter.coarse_beams, FloorMatcherOptions().filter.coarse_beams);
  EXPECT_EQ(o.filter.coarse_beams, shipped::floor_matcher::floor_matcher::filter::coarse_beams);
  // The filter's motion noise and KLD constants are not keys of the matcher.
  EXPECT_THROW(readFloorMatcherOptions(
                   common::ConfigNode::loadString("filter:\n  motion:\n    rot_rot: 0.2\n")),
               common::ConfigError);
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

// The defaults a program gets without a file are the shipped file's, section by section.
TEST(FloorMatcherOptions, DefaultsEqualTheShippedFile) {
  const auto node =
      common::ConfigNode::loadFile(storey::test::sourceDir() + "/config/floor_matcher.yaml");
  const FloorMatcherOptions f = readFloorMatcherOptions(node.child("floor_matcher"));
  const FloorMatcherOptions d;
  EXPECT_EQ(f.filter.initial_particles_per_m2, d.filter.initial_particles_per_m2);
  EXPECT_EQ(f.filter.max_particles, d.filter.max_particles);
  EXPECT_EQ(f.filter.min_particles, d.filter.min_particles);
  EXPECT_EQ(f.filter.beams, d.filter.beams);
  EXPECT_EQ(f.filter.coarse_beams, d.filter.coarse_beams);
  EXPECT_EQ(f.filter.coarse_particles, d.filter.coarse_particles);
  EXPECT_EQ(f.filter.effective_beams, d.filter.effective_beams);
  EXPECT_EQ(f.filter.convergence_mass, d.filter.convergence_mass);
  EXPECT_EQ(f.filter.convergence_radius, d.filter.convergence_radius);
  EXPECT_EQ(f.filter.convergence_angle, d.filter.convergence_angle);
  EXPECT_EQ(f.floor_change.radius, d.floor_change.radius);
  EXPECT_EQ(f.floor_change.heading, d.floor_change.heading);
  EXPECT_EQ(f.ransac_distortion, d.ransac_distortion);
  EXPECT_EQ(f.match_self_similar, d.match_self_similar);
  EXPECT_EQ(f.learning_particles, d.learning_particles);
  EXPECT_EQ(f.normal_tilt_stddev, d.normal_tilt_stddev);
  EXPECT_EQ(f.seed, d.seed);
  const RetractionOptions r = readRetractionOptions(node.child("retraction"));
  const RetractionOptions rd;
  EXPECT_EQ(r.enabled, rd.enabled);
  EXPECT_EQ(r.translation, rd.translation);
  EXPECT_EQ(r.rotation, rd.rotation);
  EXPECT_EQ(r.weak_sigmas, rd.weak_sigmas);
  EXPECT_EQ(r.confirm_growth, rd.confirm_growth);
  EXPECT_EQ(r.confirm_both_sides, rd.confirm_both_sides);
}
}  // namespace
}  // namespace storey::matching
