// Every shipped bringup file reads cleanly against storey's component catalog, and each
// of its processes comes up (create, configure with strict parameters, activate) and down.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>

#include "storey/catalog/all_components.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/runner.h"
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

}  // namespace
}  // namespace storey::runtime

namespace storey::runtime {
namespace {

// The storey binary end to end: one child process per bringup process, the domain from
// ROS_DOMAIN_ID, a clean stop after --duration.
TEST(ShippedBringupFiles, StoreyLaunchRunsAndStops) {
  const std::string bringup = storey::test::sourceDir() + "/bringup/floor_detector.yaml";
  const std::string command = "ROS_DOMAIN_ID=131 " + std::string(STOREY_EXECUTABLE) + " launch " +
                              bringup + " --duration 1.5 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[256];
  while (fgets(buffer, sizeof(buffer), pipe)) output += buffer;
  const int status = pclose(pipe);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << output;
  EXPECT_NE(output.find("started process 'robot1_floor_detector'"), std::string::npos) << output;
  EXPECT_NE(output.find("on domain 131"), std::string::npos) << output;
}

}  // namespace
}  // namespace storey::runtime
