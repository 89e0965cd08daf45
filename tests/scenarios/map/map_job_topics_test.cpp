// `storey map` on a plain ROS 2 bag whose topics are named as the robot names them
// (scan_topic, odom_topic, imu_topic, pressure_topic in the parameter files).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "storey/building/building_graph.h"
#include "storey/common/config.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/map_job.h"
#include "storey/tools/simulation_bag.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;

constexpr int kTopicsDomain = 186;

// `from` copied into `to` with its topics renamed (`names`: old -> new; others kept).
void copyRenamed(const std::string& from, const std::string& to,
                 const std::map<std::string, std::string>& names) {
  bag::BagReader reader(from);
  bag::BagWriter writer(to);
  auto renamed = [&](const std::string& topic) {
    const auto it = names.find(topic);
    return it == names.end() ? topic : it->second;
  };
  for (bag::TopicInfo topic : reader.topics()) {
    topic.name = renamed(topic.name);
    writer.createTopic(topic);
  }
  bag::BagMessage m;
  while (reader.next(m))
    writer.write(renamed(reader.topics()[m.topic_index].name), m.stamp_ns, m.data);
  writer.close();
}

// The shipped parameter files with the topic keys set to a robot's own names.
std::string configWithTopics(const std::string& dir, const std::string& scan,
                             const std::string& odom) {
  std::string config = dir + "/config";
  fs::create_directories(config);
  for (const char* kind : {"floor_detector", "floor_mapper", "floor_matcher", "graph_server"}) {
    std::string text = test::readFile(defaultConfigDir() + "/" + kind + ".yaml");
    auto set = [&](const std::string& key, const std::string& value) {
      const std::size_t at = text.find("\n" + key + ": ");
      if (at == std::string::npos) return;
      const std::size_t end = text.find(' ', at + key.size() + 3);
      text.replace(at + key.size() + 3, end - (at + key.size() + 3), value);
    };
    set("scan_topic", scan);
    set("odom_topic", odom);
    set("imu_topic", "/imu/data");
    set("pressure_topic", "/barometer");
    test::writeFile(config + "/" + kind + ".yaml", text);
  }
  fs::copy(defaultConfigDir() + "/buildings", config + "/buildings", fs::copy_options::recursive);
  fs::copy(defaultConfigDir() + "/robots", config + "/robots", fs::copy_options::recursive);
  return config;
}

// small2's recording with a single robot's usual names (no namespace, odometry from a
// filter, the IMU's driver topic): mapped with those names set, it gives the building the
// simulator's names give; with the shipped names, an error naming what was not read.
TEST(MapJobTopics, APlainBagWithItsOwnTopicNamesMaps) {
  const std::string dir = test::makeTempDir("storey_map_topics");
  const sim::Simulation run = sim::simulate(
      sim::loadScenario((fs::path(defaultConfigDir()) / "buildings" / "small2.yaml").string()),
      sim::SimulateOptions{});
  writeSimulationBag(run, dir + "/sim");
  copyRenamed(dir + "/sim", dir + "/plain",
              {{"/robot1/scan", "/front/scan"},
               {"/robot1/odom", "/odometry/filtered"},
               {"/robot1/imu", "/imu/data"},
               {"/robot1/pressure", "/barometer"}});

  MapJobOptions options;
  options.domain_id = kTopicsDomain;
  options.quiet = true;
  options.output_dir = dir + "/reference";
  options.inputs = {parseMapInput(dir + "/sim")};
  runMapJob(options);

  options.output_dir = dir + "/plain_out";
  options.inputs = {parseMapInput(dir + "/plain")};
  try {
    runMapJob(options);
    FAIL() << "a bag of other names mapped with the shipped ones";
  } catch (const std::runtime_error& e) {
    // /front/scan is robot front's scan with the shipped names; the other topics are not read.
    EXPECT_NE(std::string(e.what()).find("topics not read: /odometry/filtered"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("robot 'front' without odometry"), std::string::npos)
        << e.what();
  }

  options.config_dir = configWithTopics(dir, "/front/scan", "/odometry/filtered");
  runMapJob(options);
  const auto reference = common::ConfigNode::loadFile(dir + "/reference/building.yaml").yaml();
  const auto plain = common::ConfigNode::loadFile(dir + "/plain_out/building.yaml").yaml();
  ASSERT_EQ(plain["floor_graphs"].size(), reference["floor_graphs"].size());
  ASSERT_EQ(plain["floor_graphs"].size(), 2u);
  for (std::size_t i = 0; i < plain["floor_graphs"].size(); ++i) {
    const YAML::Node a = plain["floor_graphs"][i], b = reference["floor_graphs"][i];
    EXPECT_EQ(a["floor"].as<int>(), b["floor"].as<int>());
    EXPECT_NEAR(a["height"].as<double>(), b["height"].as<double>(), 1e-6);
    // The same building but for rounding (graph ids differ with the robot's name): 1 mm and
    // 0.01° where the goal is 0.05 m and 0.2°.
    EXPECT_NEAR(a["transform"]["x"].as<double>(), b["transform"]["x"].as<double>(), 1e-3);
    EXPECT_NEAR(a["transform"]["y"].as<double>(), b["transform"]["y"].as<double>(), 1e-3);
    EXPECT_NEAR(a["transform"]["theta"].as<double>(), b["transform"]["theta"].as<double>(),
                0.01 * M_PI / 180);
  }
}

// The two components of a robot must read the same topics.
TEST(MapJobTopics, DetectorAndMapperNamingOtherTopicsIsAnError) {
  const std::string dir = test::makeTempDir("storey_map_topics_differ");
  const std::string config = configWithTopics(dir, "/front/scan", "/odometry/filtered");
  std::string mapper = test::readFile(config + "/floor_mapper.yaml");
  mapper.replace(mapper.find("/front/scan"), 11, "/rear/scan");
  test::writeFile(config + "/floor_mapper.yaml", mapper);
  MapJobOptions options;
  options.domain_id = kTopicsDomain;
  options.quiet = true;
  options.config_dir = config;
  options.output_dir = dir + "/out";
  try {
    runMapJob(options);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("floor_mapper.yaml: scan_topic '/rear/scan'"), std::string::npos) << what;
    EXPECT_NE(what.find("floor_detector.yaml"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace storey::tools
