// `storey floors` end to end: simulate a building into a bag, then find the floor changes
// in the bag and compare them with the ground truth.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "test_support.h"

namespace {

// Runs a shell command; returns its exit status and appends its output to `output`.
int runCommand(const std::string& command, std::string& output) {
  const storey::test::CommandResult result = storey::test::runCommand(command);
  output += result.output;
  return result.status;
}

TEST(FloorsCommand, FindsTheSimulatedRidesInABag) {
  const std::string dir = storey::test::makeTempDir("floors_cmd");
  const std::string storey = STOREY_COMMAND;
  std::string out;
  ASSERT_EQ(runCommand(storey + " simulate " + storey::test::sourceDir() +
                           "/config/buildings/small2.yaml --seed 4 --no-pictures --output " + dir,
                       out),
            0)
      << out;
  out.clear();
  ASSERT_EQ(runCommand(storey + " floors " + dir + "/bag --ground-truth " + dir +
                           "/ground_truth --config " + storey::test::sourceDir() +
                           "/config/floor_detector.yaml",
                       out),
            0)
      << out;
  std::printf("%s", out.c_str());
  EXPECT_NE(out.find("floor sequence: 0 1 0"), std::string::npos) << out;
  EXPECT_NE(out.find("0 missed, 0 spurious, 0 wrong floors"), std::string::npos) << out;
}

TEST(FloorsCommand, MissingBagIsAnError) {
  std::string out;
  EXPECT_NE(runCommand(std::string(STOREY_COMMAND) + " floors /nonexistent/bag", out), 0);
  EXPECT_FALSE(out.empty());
}

}  // namespace
