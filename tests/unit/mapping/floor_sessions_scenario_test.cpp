// Floor sessions on a floor symmetric under a half turn: a robot that comes back cannot
// tell which half it is in, and must start a new graph rather than tie to the mirror.
#include <gtest/gtest.h>

#include "floor_sessions_world.h"
#include "storey/mapping/floor_sessions.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;
using test::legs;
using test::Robot;
using test::symmetricFloor;
using test::upperFloor;

TEST(FloorSessions, SymmetricFloorGivesANewGraphNotAWrongTie) {
  const test::World floor0 = symmetricFloor();
  for (std::uint64_t seed : {1u}) {
    FloorSlamOptions options;
    options.relocalization.global.seed = seed;
    const Pose2 start(1, 8, 0);
    Robot robot(options, start);
    // Both halves mapped: the map is as symmetric as the floor.
    robot.drive(
        floor0,
        legs({{1, 8}, {9, 8}, {8, 5}, {15, 5}, {8, 5}, {2, 4}, {7, 3}, {8, 1}, {15, 1}}, 0.0));
    robot.ride(1, 3.0, Pose2(1, 1, 0.5));
    robot.drive(upperFloor(), legs({{1, 1}, {6, 1}}, 0.5));
    // Return where the symmetric view is as good as the true one.
    const auto back = legs({{15, 2}, {8, 2}, {8, 5}, {13, 6}}, M_PI);
    robot.ride(0, 0.0, back.front());
    const auto results = robot.drive(floor0, back);
    robot.sessions.flush();
    const auto& stats = robot.sessions.stats();
    EXPECT_EQ(stats.global_relocalizations + stats.fallbacks, 1u) << "seed " << seed;
    // Whatever it decided, a relocalised pose must be the true one (never the mirror).
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (!results[i].relocalized) continue;
      const Pose2 expected = start.between(back[i]);
      EXPECT_LT((results[i].pose.translation() - expected.translation()).norm(), 0.1)
          << "seed " << seed;
    }
    // Here the views are symmetric all along: it must not commit.
    EXPECT_EQ(stats.global_relocalizations, 0u) << "seed " << seed;
    EXPECT_EQ(robot.sessions.retired().size(), 1u) << "seed " << seed;
    EXPECT_FALSE(robot.sessions.current().floorGraph().nodes.empty());
  }
}

}  // namespace
}  // namespace storey::mapping
