// Every shipped bringup file reads cleanly against storey's component catalog, and each
// of its processes comes up (create, configure with strict parameters, activate) and down.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "storey/catalog/all_components.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/runner.h"
#include "storey/sim/scenario.h"
#include "storey/tools/map_job.h"
#include "storey/tools/robot_setup.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

TEST(ShippedBringupFiles, EveryFileReadsAndStarts) {
  ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  const auto folder = std::filesystem::path(storey::test::sourceDir()) / "bringup";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() != ".yaml") continue;
    ++files;
    SCOPED_TRACE(entry.path().string());
    Bringup bringup;
    ASSERT_NO_THROW(bringup = readBringup(entry.path().string(), registry));
    for (const auto& process : bringup.processes) {
      ContextOptions options;
      options.domain_id = 130;  // this test's own domain, whatever the file says
      Context context(options);
      ComponentGroup group(context, process.components, registry);
      EXPECT_NO_THROW(group.start()) << "process " << process.name;
      group.stop();
    }
  }
  std::printf("checked %d bringup file(s) in %s\n", files, folder.c_str());
}

// `storey simulate` writes live/live.yaml: the simulated robots' components with the
// parameters `storey map` gives them (robot model's mapper tuning, the fleet's floors),
// which a live run of the shipped bringup files lacked.
TEST(SimulationLiveBringup, CarriesEachRobotsSetupAndStarts) {
  const std::string config_dir = tools::defaultConfigDir();
  const sim::Scenario fleet = sim::loadScenario(config_dir + "/buildings/fleet.yaml");
  const tools::RobotSetup setup = tools::robotSetup(fleet);
  const std::string dir = storey::test::makeTempDir("live_bringup");
  const std::vector<std::string> robots{"robot1", "robot3"};
  const std::string file = tools::writeLiveBringup(config_dir, robots, setup, dir + "/live", dir + "/bag");

  ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  Bringup bringup;
  ASSERT_NO_THROW(bringup = readBringup(file, registry));
  ASSERT_EQ(bringup.processes.size(), 1u);
  std::vector<std::string> names;
  for (const auto& c : bringup.processes[0].components) names.push_back(c.name);
  EXPECT_EQ(names, (std::vector<std::string>{"floor_detector_robot1", "floor_mapper_robot1", "floor_detector_robot3",
                                             "floor_mapper_robot3", "floor_matcher", "graph_server"}));

  // robot3 starts on F3, the fourth floor: its detector and mapper know it, and its mapper
  // takes the default robot model's laser range noise.
  const auto detector = loadParameters(bringup.processes[0].components[2]);
  EXPECT_EQ(detector.yaml()["robot"].as<std::string>(), "robot3");
  EXPECT_EQ(detector.yaml()["detector"]["floors"]["initial_floor"].as<int>(), 3);
  EXPECT_EQ(detector.yaml()["detector"]["floors"]["heights"].size(), setup.floor_heights.size());
  const auto mapper = loadParameters(bringup.processes[0].components[3]);
  EXPECT_EQ(mapper.yaml()["initial_floor"].as<int>(), 3);
  EXPECT_DOUBLE_EQ(mapper.yaml()["initial_height"].as<double>(), setup.floor_heights[3]);
  ASSERT_TRUE(setup.laser_range_noise.count("robot3"));
  EXPECT_DOUBLE_EQ(mapper.yaml()["slam"]["laser"]["range_noise"].as<double>(),
                   setup.laser_range_noise.at("robot3"));
  const auto server = loadParameters(bringup.processes[0].components[5]);
  EXPECT_EQ(server.yaml()["journal"].as<std::string>(), std::filesystem::absolute(dir + "/live/journal.bin").string());

  // And it comes up with strict parameters, as a launch would bring it.
  ContextOptions options;
  options.domain_id = 132;
  Context context(options);
  ComponentGroup group(context, bringup.processes[0].components, registry);
  EXPECT_NO_THROW(group.start());
  group.stop();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace storey::runtime

namespace storey::runtime {
namespace {

// The storey binary end to end: one child process per bringup process, the domain from
// ROS_DOMAIN_ID, a clean stop after --duration.
TEST(ShippedBringupFiles, StoreyLaunchRunsAndStops) {
  const std::string bringup = storey::test::sourceDir() + "/bringup/floor_detector.yaml";
  const std::string command = "ROS_DOMAIN_ID=131 " + std::string(STOREY_EXECUTABLE) + " launch " +
                              bringup + " --duration 1.5";
  const auto [status, output] = storey::test::runCommand(command);
  EXPECT_EQ(status, 0) << output;
  EXPECT_NE(output.find("started process 'robot1_floor_detector'"), std::string::npos) << output;
  EXPECT_NE(output.find("on domain 131"), std::string::npos) << output;
}

}  // namespace
}  // namespace storey::runtime
