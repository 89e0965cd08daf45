// The front end's options: the shipped file, the laser model, strict reading.
#include "storey/mapping/floor_slam_options.h"

#include <gtest/gtest.h>

#include "storey/common/config.h"
#include "test_support.h"

namespace storey::mapping {
namespace {

TEST(FloorSlamOptions, TheShippedFileIsTheLibrarysDefaults) {
  const auto root =
      common::ConfigNode::loadFile(storey::test::sourceDir() + "/config/floor_mapper.yaml");
  const FloorSlamOptions shipped = readFloorSlamOptions(root.child("slam"));
  const FloorSlamOptions defaults;
  EXPECT_DOUBLE_EQ(shipped.laser.range_noise, defaults.laser.range_noise);
  EXPECT_DOUBLE_EQ(shipped.odometry.translation_per_meter, defaults.odometry.translation_per_meter);
  EXPECT_DOUBLE_EQ(shipped.odometry.rotation_per_meter, defaults.odometry.rotation_per_meter);
  EXPECT_DOUBLE_EQ(shipped.odometry.rotation_per_radian, defaults.odometry.rotation_per_radian);
  EXPECT_DOUBLE_EQ(shipped.local_map.resolution, defaults.local_map.resolution);
  EXPECT_DOUBLE_EQ(shipped.node.min_translation, defaults.node.min_translation);
  EXPECT_DOUBLE_EQ(shipped.node.min_rotation, defaults.node.min_rotation);
  EXPECT_EQ(shipped.local_map.max_nodes, defaults.local_map.max_nodes);
  EXPECT_EQ(shipped.loop_closure.enabled, defaults.loop_closure.enabled);
  EXPECT_EQ(shipped.relocalization.known_floor, defaults.relocalization.known_floor);
  EXPECT_EQ(shipped.relocalization.global.seed, defaults.relocalization.global.seed);
  EXPECT_DOUBLE_EQ(shipped.matcher.min_point_stddev, defaults.matcher.min_point_stddev);
  EXPECT_DOUBLE_EQ(shipped.loop_closure.point_polish_translation,
                   defaults.loop_closure.point_polish_translation);
}

TEST(FloorSlamOptions, TheLaserModelSetsTheNoiseFloors) {
  const FloorSlamOptions real =
      readFloorSlamOptions(common::ConfigNode::loadString("laser: {range_noise: 0.04}\n"));
  EXPECT_DOUBLE_EQ(real.matcher.min_point_stddev, 0.02);
  EXPECT_DOUBLE_EQ(real.matcher.min_translation_stddev, 0.01);
  EXPECT_DOUBLE_EQ(real.loop_closure.point_polish_translation, 0.0);  // points no finer than cells
  // A precise laser: finer floors, and closures polished on the map's points.
  const FloorSlamOptions clean =
      readFloorSlamOptions(common::ConfigNode::loadString("laser: {range_noise: 0.01}\n"));
  EXPECT_DOUBLE_EQ(clean.matcher.min_point_stddev, 0.005);
  EXPECT_DOUBLE_EQ(clean.loop_closure.matcher.min_point_stddev, 0.005);
  EXPECT_DOUBLE_EQ(clean.matcher.min_translation_stddev, 0.0025);
  EXPECT_DOUBLE_EQ(clean.loop_closure.point_polish_translation, 0.05);
  // The resolution sets the point filter and cells.
  const FloorSlamOptions fine =
      readFloorSlamOptions(common::ConfigNode::loadString("map_resolution: 0.025\n"));
  EXPECT_DOUBLE_EQ(fine.local_map.point_cell_size, 0.025);
  EXPECT_DOUBLE_EQ(fine.matcher.point_filter_distance, 0.025);
}

TEST(FloorSlamOptions, KeysAreReadStrictly) {
  auto read = [](const std::string& text) {
    return readFloorSlamOptions(common::ConfigNode::loadString(text));
  };
  EXPECT_EQ(read("local_map_nodes: 7\n").local_map.max_nodes, 7);
  EXPECT_FALSE(read("loop_closure: false\n").loop_closure.enabled);
  EXPECT_EQ(read("relocalization: {known_floor: new_graph, seed: 4}\n").relocalization.global.seed,
            4u);
  EXPECT_THROW(read("local_map_nodes: 1\n"), common::ConfigError);
  EXPECT_THROW(read("node_spacing: {translaton: 1}\n"), common::ConfigError);
  EXPECT_THROW(read("laser: {range_noise: 0}\n"), common::ConfigError);
  EXPECT_THROW(read("scan_matcher: {min_score: 0.3}\n"), common::ConfigError);
  EXPECT_THROW(read("relocalization: {known_floor: guess}\n"), common::ConfigError);
  EXPECT_THROW(read("bogus: 1\n"), common::ConfigError);
}

}  // namespace
}  // namespace storey::mapping
