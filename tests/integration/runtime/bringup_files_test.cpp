// Every shipped bringup file reads cleanly against storey's component catalog, and each
// of its processes comes up (create, configure with strict parameters, activate) and down.
#include <gtest/gtest.h>

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
