// The report's warnings from `storey map`: what a person must look at besides the floors.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/map_job.h"
#include "storey/tools/simulation_bag.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;

// A robot whose odometry stops early in the recording: most of its scans cannot be mapped,
// and the report's summary says so, naming the robot.
TEST(MapJobWarnings, MostlyUnmappedScansAreFlagged) {
  const std::string dir = test::makeTempDir("storey_map_no_odometry");
  sim::Simulation run = sim::simulate(
      sim::loadScenario((fs::path(defaultConfigDir()) / "buildings" / "small2.yaml").string()),
      sim::SimulateOptions{});
  auto& robot = run.robots.at(0);
  auto& odometry = robot.odometry;
  const double end =
      odometry.front().stamp + 0.3 * (odometry.back().stamp - odometry.front().stamp);
  odometry.erase(std::remove_if(odometry.begin(), odometry.end(),
                                [&](const sensor::OdometrySample& s) { return s.stamp > end; }),
                 odometry.end());
  writeSimulationBag(run, dir + "/bag");
  MapJobOptions options;
  options.domain_id = 169;
  options.output_dir = dir + "/out";
  options.quiet = true;
  options.inputs = {parseMapInput(dir + "/bag")};
  runMapJob(options);
  const std::string report = test::readFile(dir + "/out/report.html");
  const std::string warning = "<li class=\"warn\">" + robot.name + ": ";
  const std::size_t at = report.find(warning);
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(at, report.find("<h2>Floors</h2>"));  // on the first screen
  EXPECT_NE(report.find("without odometry within max_odometry_gap", at), std::string::npos);
}

}  // namespace
}  // namespace storey::tools
