#include "storey/geometry/frame_tree.h"

#include <gtest/gtest.h>

#include <cmath>

namespace storey::geometry {
namespace {

void expectPose(const std::optional<Pose2>& pose, double x, double y, double theta) {
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR(pose->x(), x, 1e-12);
  EXPECT_NEAR(pose->y(), y, 1e-12);
  EXPECT_NEAR(pose->theta(), theta, 1e-12);
}

TEST(FrameTree, ComposesTheChainUpToTheFirstBaseGiven) {
  FrameTree tree;
  tree.set("base_footprint", "base_link", Pose2(0.1, 0.0, 0.0));
  tree.set("base_link", "laser", Pose2(0.2, 0.0, M_PI / 2));
  tree.set("laser", "laser_optical", Pose2(0.0, 0.5, 0.0));
  expectPose(tree.poseInFirstOf("laser", {"base_link"}), 0.2, 0.0, M_PI / 2);
  expectPose(tree.poseInFirstOf("laser", {"base_footprint", "base_link"}), 0.3, 0.0, M_PI / 2);
  // base_link's pose in base_footprint applied after laser's in base_link.
  expectPose(tree.poseInFirstOf("laser_optical", {"base_footprint"}), -0.2, 0.0, M_PI / 2);
  expectPose(tree.poseInFirstOf("base_link", {"base_link"}), 0.0, 0.0, 0.0);  // itself
  EXPECT_FALSE(tree.poseInFirstOf("laser", {"robot1/base_link"}).has_value());
  EXPECT_FALSE(tree.poseInFirstOf("camera", {"base_link"}).has_value());
}

TEST(FrameTree, ALaterTransformReplacesTheChildsParent) {
  FrameTree tree;
  tree.set("base_link", "laser", Pose2(0.2, 0.0, 0.0));
  tree.set("base_link", "laser", Pose2(0.4, 0.0, 0.0));
  expectPose(tree.poseInFirstOf("laser", {"base_link"}), 0.4, 0.0, 0.0);
  tree.set("robot1/base_link", "laser", Pose2(0.1, 0.0, 0.0));
  EXPECT_FALSE(tree.poseInFirstOf("laser", {"base_link"}).has_value());
  expectPose(tree.poseInFirstOf("laser", {"base_link", "robot1/base_link"}), 0.1, 0.0, 0.0);
}

TEST(FrameTree, BadTransformsAreRefusedByName) {
  FrameTree tree;
  tree.set("a", "b", Pose2());
  tree.set("b", "c", Pose2());
  EXPECT_THROW(tree.set("c", "a", Pose2()), std::invalid_argument);
  EXPECT_THROW(tree.set("a", "a", Pose2()), std::invalid_argument);
  EXPECT_THROW(tree.set("", "x", Pose2()), std::invalid_argument);
  try {
    tree.set("c", "a", Pose2());
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("cycle"), std::string::npos) << e.what();
  }
  expectPose(tree.poseInFirstOf("c", {"a"}), 0.0, 0.0, 0.0);  // unchanged by the refusals
}

}  // namespace
}  // namespace storey::geometry
