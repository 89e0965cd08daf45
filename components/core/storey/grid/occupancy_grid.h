// A log-odds occupancy grid built from laser scans at known poses, with exact ray
// traversal (Amanatides & Woo) and bounds that grow as scans reach new space.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/grid/grid2.h"
#include "storey/grid/image.h"
#include "storey/sensor/laser_scan.h"

namespace storey::grid {

struct OccupancyGridOptions {
  double resolution = 0.05;       // metres per cell
  double hit_log_odds = 0.85;     // added to the endpoint cell of a return
  double miss_log_odds = -0.4;    // added to each cell a beam passes through
  double min_log_odds = -2.0;     // clamping keeps maps able to change
  double max_log_odds = 3.5;
  bool free_space_for_no_return = false;  // clear along beams that saw nothing...
  double no_return_free_range = 10.0;     // ...up to this range (metres)
  double max_insert_range = 0.0;  // returns beyond this are treated as no return (0: range_max)
  double growth_margin = 8.0;     // m of room added around new scans whenever the grid grows
};

enum class CellState { kUnknown, kFree, kOccupied };

class OccupancyGrid {
 public:
  explicit OccupancyGrid(const OccupancyGridOptions& options = {});

  void insertScan(const sensor::LaserScan& scan, const geometry::Pose2& robot_pose);
  struct PosedScan {
    const sensor::LaserScan* scan;
    geometry::Pose2 robot_pose;
  };
  // The same as insertScan on each in turn, but the grid grows once, to all of them (no
  // copies of a grid growing scan by scan; with a small growth_margin, a tight grid).
  void insertScans(const std::vector<PosedScan>& scans);
  // Grows the grid (if needed) so that the axis-aligned box is inside it.
  void ensureContains(const Eigen::Vector2d& min_corner, const Eigen::Vector2d& max_corner);

  const GridFrame& frame() const { return log_odds_.frame; }
  const Grid2<float>& logOdds() const { return log_odds_; }
  float logOddsAt(int cx, int cy) const { return log_odds_.valueOr(cx, cy, 0.0f); }
  double probabilityAt(int cx, int cy) const;
  CellState stateAt(int cx, int cy, double occupied_threshold = 0.65,
                    double free_threshold = 0.196) const;
  bool empty() const { return log_odds_.frame.width == 0; }
  const OccupancyGridOptions& options() const { return options_; }
  // Cell counts per state (unknown, free, occupied).
  std::array<std::size_t, 3> countStates() const;

 private:
  // Calls visit(index) for each cell a ray passes through, excluding its end cell.
  template <typename Visit>
  void traceRay(const Eigen::Vector2d& from, const Eigen::Vector2d& to, Visit&& visit) const;
  void addLogOdds(std::size_t index, double delta);
  struct Beam {
    Eigen::Vector2d end;
    bool hit;  // false: a beam that proves free space only
  };
  // The scan's beams from its sensor's origin; false when there are none.
  bool collectBeams(const sensor::LaserScan& scan, const geometry::Pose2& robot_pose, Eigen::Vector2d* origin,
                    std::vector<Beam>* beams) const;
  // Updates the cells of one scan's beams (the grid must contain them).
  void applyBeams(const Eigen::Vector2d& origin, const std::vector<Beam>& beams);

  OccupancyGridOptions options_;
  Grid2<float> log_odds_;
  // Per cell, the tag of the last scan update (hit or miss tag of that scan), so each scan
  // updates a cell at most once without sorting the traversed cells.
  std::vector<std::uint16_t> marks_;  // 16 bits: cleared once every 32767 scans
  std::uint16_t last_tag_ = 0;
};

// nav2 map_server format: <stem>.pgm (trinary: 0 occupied, 254 free, 205 unknown; top row
// is the largest y) and <stem>.yaml (image, mode, resolution, origin, negate, thresholds).
// Returns the paths written; throws std::runtime_error naming the file on failure.
void writeMapServerFiles(const OccupancyGrid& grid, const std::string& stem,
                         double occupied_threshold = 0.65, double free_threshold = 0.196);
// A grey-scale picture of the grid (same convention as the PGM), top row = largest y.
Image renderGrey(const OccupancyGrid& grid, double occupied_threshold = 0.65,
                 double free_threshold = 0.196);

}  // namespace storey::grid
