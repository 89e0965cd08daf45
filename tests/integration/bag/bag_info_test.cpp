// `storey bag info` on a bag written here, and on files that are not bags.

#include <fstream>

#include "storey/runtime/sensor_bag.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

TEST(BagInfo, PrintsTopicsTypesCountsAndDuration) {
  const std::string folder = test::makeTempDir("bag_info") + "/walk";
  {
    SensorBagWriter writer(folder);
    for (int i = 0; i < 11; ++i) {
      writer.write("r1", sensor::PressureSample{100.0 + 0.5 * i, 101000.0, 0.0});
      sensor::OdometrySample odom;
      odom.stamp = 100.0 + 0.5 * i;
      writer.write("r1", odom);
    }
  }
  const auto [status, out] = test::runCommand(std::string(STOREY_COMMAND) + " bag info " + folder);
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("walk_0.db3"), std::string::npos) << out;
  EXPECT_NE(out.find("Duration:    5.000 s"), std::string::npos) << out;
  // Each odometry sample is also on /tf (odom -> base_link).
  EXPECT_NE(out.find("Messages:    33"), std::string::npos) << out;
  EXPECT_NE(out.find("schema 3, humble"), std::string::npos) << out;
  EXPECT_NE(out.find("/r1/pressure  sensor_msgs/msg/FluidPressure        11  cdr  2.0 Hz"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("/r1/odom      nav_msgs/msg/Odometry                11"), std::string::npos)
      << out;
  EXPECT_NE(out.find("/tf           tf2_msgs/msg/TFMessage               11"), std::string::npos)
      << out;
}

TEST(BagInfo, NonBagsFailNamingTheFile) {
  const std::string dir = test::makeTempDir("bag_info");
  std::ofstream(dir + "/junk.db3") << "this is not sqlite";
  test::CommandResult r =
      test::runCommand(std::string(STOREY_COMMAND) + " bag info " + dir + "/junk.db3");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find(dir + "/junk.db3: not a readable sqlite3 database"), std::string::npos)
      << r.output;
  r = test::runCommand(std::string(STOREY_COMMAND) + " bag info " + dir + "/missing");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find(dir + "/missing: no such bag folder or file"), std::string::npos)
      << r.output;
  r = test::runCommand(std::string(STOREY_COMMAND) + " bag list " + dir);
  EXPECT_EQ(r.status, 2) << r.output;
}

}  // namespace
}  // namespace storey::runtime
