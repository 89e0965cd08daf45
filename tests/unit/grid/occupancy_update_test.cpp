// The update rule of insertScan, checked on single cells: one update per cell per scan, an
// endpoint is never cleared by a beam through it, and growth keeps the rule.
#include <gtest/gtest.h>

#include <cmath>

#include "storey/grid/occupancy_grid.h"

namespace storey::grid {
namespace {

sensor::LaserScan beams(std::vector<float> ranges, double angle_min, double increment) {
  sensor::LaserScan scan;
  scan.angle_min = angle_min;
  scan.angle_increment = increment;
  scan.range_min = 0.01;
  scan.range_max = 30.0;
  scan.ranges = std::move(ranges);
  return scan;
}

float logOddsAtWorld(const OccupancyGrid& grid, double x, double y) {
  const Eigen::Vector2i c = grid.frame().cellOf({x, y});
  return grid.logOddsAt(c.x(), c.y());
}

TEST(OccupancyUpdate, OneUpdatePerCellPerScanAndEndpointsWin) {
  OccupancyGridOptions options;
  options.resolution = 0.1;
  OccupancyGrid grid(options);
  // Three beams along +x from (0.05, 0.05): two end in the cell at x = 1.05 (one of them
  // twice over, as a duplicate beam), one passes through it and ends at x = 2.05.
  const auto scan = beams({1.0f, 1.0f, 2.0f}, 0.0, 1e-9);
  grid.insertScan(scan, geometry::Pose2(0.05, 0.05, 0.0));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 1.05, 0.05), static_cast<float>(options.hit_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 2.05, 0.05), static_cast<float>(options.hit_log_odds));
  // Traversed by all three beams, updated once.
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 0.55, 0.05), static_cast<float>(options.miss_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 1.55, 0.05), static_cast<float>(options.miss_log_odds));
  EXPECT_EQ(logOddsAtWorld(grid, 0.55, 0.35), 0.0f);  // never observed
  // A second scan updates every cell again, once.
  grid.insertScan(scan, geometry::Pose2(0.05, 0.05, 0.0));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 1.05, 0.05), static_cast<float>(2 * options.hit_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 0.55, 0.05), static_cast<float>(2 * options.miss_log_odds));
}

TEST(OccupancyUpdate, ClampsAndKeepsObservedCellsNonZero) {
  OccupancyGridOptions options;
  options.resolution = 0.1;
  options.hit_log_odds = 0.4;
  options.miss_log_odds = -0.4;
  OccupancyGrid grid(options);
  grid.insertScan(beams({1.0f}, 0.0, 0.1), geometry::Pose2(0.05, 0.05, 0.0));
  // A miss that brings the cell back to exactly zero keeps it "observed".
  grid.insertScan(beams({2.0f}, 0.0, 0.1), geometry::Pose2(0.05, 0.05, 0.0));
  EXPECT_NE(logOddsAtWorld(grid, 1.05, 0.05), 0.0f);
  EXPECT_NE(
      grid.stateAt(grid.frame().cellOf({1.05, 0.05}).x(), grid.frame().cellOf({1.05, 0.05}).y()),
      CellState::kOccupied);
  for (int i = 0; i < 50; ++i)
    grid.insertScan(beams({2.0f}, 0.0, 0.1), geometry::Pose2(0.05, 0.05, 0.0));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 2.05, 0.05), static_cast<float>(options.max_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 1.05, 0.05), static_cast<float>(options.min_log_odds));
}

TEST(OccupancyUpdate, RuleHoldsAcrossGrowth) {
  OccupancyGridOptions options;
  options.resolution = 0.1;
  OccupancyGrid grid(options);
  grid.insertScan(beams({1.0f}, 0.0, 0.1), geometry::Pose2(0.05, 0.05, 0.0));
  const int width_before = grid.frame().width;
  // Far away: the grid grows, then the same scan pattern must update once per cell.
  grid.insertScan(beams({1.0f, 1.0f, 2.0f}, 0.0, 1e-9), geometry::Pose2(40.05, 0.05, 0.0));
  ASSERT_GT(grid.frame().width, width_before);
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 41.05, 0.05), static_cast<float>(options.hit_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 40.55, 0.05), static_cast<float>(options.miss_log_odds));
  EXPECT_FLOAT_EQ(logOddsAtWorld(grid, 1.05, 0.05), static_cast<float>(options.hit_log_odds));
}

TEST(OccupancyUpdate, RuleHoldsWhenTheScanTagsWrapAround) {
  // The per-cell tags are 16 bits: after 32767 scans they are cleared and reused. Small
  // steps and wide clamps make every update visible in the sums.
  OccupancyGridOptions options;
  options.resolution = 0.1;
  options.hit_log_odds = 0.001;
  options.miss_log_odds = -0.001;
  options.max_log_odds = 100.0;
  options.min_log_odds = -100.0;
  OccupancyGrid grid(options);
  const auto scan = beams({1.0f, 1.0f, 2.0f}, 0.0, 1e-9);
  constexpr int kScans = 33000;
  for (int i = 0; i < kScans; ++i) grid.insertScan(scan, geometry::Pose2(0.05, 0.05, 0.0));
  EXPECT_NEAR(logOddsAtWorld(grid, 1.05, 0.05), kScans * 0.001, 0.05);
  EXPECT_NEAR(logOddsAtWorld(grid, 0.55, 0.05), -kScans * 0.001, 0.05);
}

TEST(OccupancyUpdate, InsertingScansTogetherEqualsOneByOne) {
  OccupancyGridOptions roomy;
  roomy.resolution = 0.1;
  OccupancyGridOptions tight = roomy;
  tight.growth_margin = 0.3;
  // Scans that overlap (the later ones clear and re-hit cells of the earlier ones) and
  // reach beyond each other's boxes (one by one, the grid grows twice).
  const sensor::LaserScan near_scan = beams({1.0f, 1.5f, 2.0f, 0.0f}, -0.5, 0.3);
  const sensor::LaserScan far_scan = beams({3.0f, 3.0f, 6.0f}, 0.2, 0.2);
  const std::vector<OccupancyGrid::PosedScan> scans = {{&near_scan, geometry::Pose2(0.05, 0.05, 0.0)},
                                                       {&far_scan, geometry::Pose2(0.35, 0.15, 0.4)},
                                                       {&near_scan, geometry::Pose2(12.0, -3.0, 2.0)},
                                                       {&far_scan, geometry::Pose2(0.05, 0.05, 0.1)}};
  OccupancyGrid one_by_one(roomy), together(tight);
  for (const auto& s : scans) one_by_one.insertScan(*s.scan, s.robot_pose);
  together.insertScans(scans);
  // Every cell either grid holds has the same log-odds in both (0 where unobserved).
  int observed = 0;
  for (const OccupancyGrid* g : {&one_by_one, &together}) {
    const GridFrame& f = g->frame();
    for (int cy = 0; cy < f.height; ++cy)
      for (int cx = 0; cx < f.width; ++cx) {
        const Eigen::Vector2d centre(f.origin_x + (cx + 0.5) * f.resolution, f.origin_y + (cy + 0.5) * f.resolution);
        const float value = g->logOddsAt(cx, cy);
        observed += value != 0.0f;
        ASSERT_EQ(logOddsAtWorld(one_by_one, centre.x(), centre.y()), value) << centre.transpose();
        ASSERT_EQ(logOddsAtWorld(together, centre.x(), centre.y()), value) << centre.transpose();
      }
  }
  EXPECT_GT(observed, 100);
  // The tight grid ends 0.3 m (3 cells, rounded out to the cell) beyond the scans.
  EXPECT_LT(together.frame().cellCount(), one_by_one.frame().cellCount() / 4);
}

// A pose 1e9 m away or a range of 1e30 m would need a grid beyond any memory: refused,
// naming the extent and the limit; the grid is unchanged.
TEST(OccupancyUpdate, AScanOutOfReachIsRefusedNamingTheExtent) {
  OccupancyGrid grid;
  grid.insertScan(beams({2.0f, 2.0f, 2.0f}, -0.1, 0.1), geometry::Pose2());
  const GridFrame before = grid.frame();
  for (const auto& [scan, pose] :
       {std::pair{beams({2.0f}, 0.0, 0.1), geometry::Pose2(1e9, 0.0, 0.0)},
        std::pair{[] {
                    sensor::LaserScan s = beams({1e30f}, 0.0, 0.1);
                    s.range_max = 1e31f;
                    return s;
                  }(),
                  geometry::Pose2()}}) {
    try {
      grid.insertScan(scan, pose);
      ADD_FAILURE() << "accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("cells a map may hold"), std::string::npos) << e.what();
    }
    EXPECT_EQ(grid.frame().width, before.width);
    EXPECT_EQ(grid.frame().height, before.height);
  }
}

}  // namespace
}  // namespace storey::grid
