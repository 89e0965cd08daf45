// `storey floors` end to end: simulate a building into a bag, then find the floor changes
// in the bag and compare them with the ground truth.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "test_support.h"

namespace {

TEST(FloorsCommand, FindsTheSimulatedRidesInABag) {
  const std::string dir = storey::test::makeTempDir("floors_cmd");
  const std::string storey = STOREY_COMMAND;
  storey::test::CommandResult r = storey::test::runCommand(
      storey + " simulate " + storey::test::sourceDir() +
      "/config/buildings/small2.yaml --seed 4 --no-pictures --output " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  r = storey::test::runCommand(storey + " floors " + dir + "/bag --ground-truth " + dir +
                               "/ground_truth --config " + storey::test::sourceDir() +
                               "/config/floor_detector.yaml");
  ASSERT_EQ(r.status, 0) << r.output;
  std::printf("%s", r.output.c_str());
  EXPECT_NE(r.output.find("floor sequence: 0 1 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0 missed, 0 spurious, 0 wrong floors"), std::string::npos) << r.output;
}

// A bag without a pressure topic: the heights come from the IMU and odometry.
TEST(FloorsCommand, FindsTheRidesOfARobotWithoutABarometer) {
  const std::string dir = storey::test::makeTempDir("floors_cmd_imu");
  const std::string storey = STOREY_COMMAND;
  storey::test::CommandResult r = storey::test::runCommand(
      storey + " simulate " + storey::test::sourceDir() +
      "/config/buildings/small2.yaml --seed 4 --no-barometer --no-pictures --output " + dir);
  ASSERT_EQ(r.status, 0) << r.output;
  r = storey::test::runCommand(storey + " floors " + dir + "/bag --ground-truth " + dir +
                               "/ground_truth");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("heights from the IMU and odometry"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("floor sequence: 0 1 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0 missed, 0 spurious, 0 wrong floors"), std::string::npos) << r.output;
}

TEST(FloorsCommand, MissingBagIsAnError) {
  storey::test::CommandResult r =
      storey::test::runCommand(std::string(STOREY_COMMAND) + " floors /nonexistent/bag");
  EXPECT_NE(r.status, 0);
  EXPECT_FALSE(r.output.empty());
}

}  // namespace
