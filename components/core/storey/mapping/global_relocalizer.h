// Global relocalisation of a robot arriving on a floor mapped before (issue #6: resume a
// known floor "after localising in its map, the same global localisation the matcher
// uses, with dz = 0").
//
// The arriving scans are buffered and fed, whenever the robot has moved enough, to the
// particle filter the floor matcher uses too (localization::ParticleFilter: KLD-sampling
// MCL over the whole floor's free space, odometry motion model, likelihood-field sensor
// model). A filter that has not converged after `max_sequence` fed scans is restarted from
// uniform particles (the robot may arrive in a place the floor map does not show, e.g. inside a
// stairwell, where no particle stands). When it converges, the estimate is checked before
// anything is tied to the old graph:
//   1. refinement: the last `refine_scans` fed scans, placed by odometry relative to the
//      last one, are matched (correlative search in a small window, then Gauss-Newton)
//      against the floor's map; the refined score must reach `min_score` and the
//      refinement must not move the estimate more than `max_refine_correction`;
//   2. uniqueness: the same points are searched over the whole map (every position and
//      heading); when a pose elsewhere fits better than the estimate, it becomes the
//      candidate (refined the same way); the best pose clearly elsewhere (farther than
//      `ambiguity_distance` or `ambiguity_angle`) must score below `ambiguity_ratio` times
//      the candidate's score.
//      A symmetric floor, where the filter may collapse onto either of two modes, fails
//      here instead of giving a confident wrong tie.
// A candidate that fails restarts the filter; after `max_scans` buffered scans without an
// accepted estimate the relocaliser gives up (the caller then opens a new graph of the
// floor for the floor matcher to align).
//
//   GlobalRelocalizer r(floor_graph, options, matcher_options, field_options, 20.0);
//   for (...) if (r.add(scan, odometry) != RelocalizationStatus::kSearching) break;
//   r.result();  // pose of the last buffered scan in the floor frame, covariance, score
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"
#include "storey/geometry/pose2.h"
#include "storey/grid/likelihood_field.h"
#include "storey/localization/particle_filter.h"
#include "storey/mapping/scan_matcher.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping {

// The shipped file's front-end values (config/floor_mapper.yaml, `slam`), the defaults below.
namespace shipped_slam = shipped::floor_mapper::slam;

struct GlobalRelocalizationOptions {
  localization::ParticleFilterOptions filter;
  grid::LikelihoodFieldOptions likelihood_field;  // the filter's sensor model
  double map_resolution = 0.05;  // m, the floor map the filter and the check use
  // A scan is fed to the filter when the robot moved or turned this much since the last
  // fed one (repeated updates with the same view would collapse the filter early).
  double feed_translation = 0.2;  // m
  double feed_rotation = 0.17;    // rad
  int min_sequence = 8;   // fed scans before convergence counts
  int max_sequence = 40;  // fed scans before the filter restarts
  int max_scans = 600;    // buffered scans before giving up
  // Check of a converged estimate (see the header comment).
  int refine_scans = 10;
  double refine_linear_window = 0.5;   // m
  double refine_angular_window = 0.2;  // rad
  double max_refine_correction = 0.5;  // m
  double min_score = 0.8;              // refined mean score
  double ambiguity_ratio = 0.9;
  double ambiguity_distance = 1.0;  // m
  double ambiguity_angle = 0.3;     // rad
  double search_tile = 8.0;         // m, side of one tile of the whole-map search
  // m, points thinned for the whole-map search
  double search_point_distance = 0.15;
  std::uint64_t seed = shipped_slam::relocalization::seed;
};

enum class RelocalizationStatus { kSearching, kLocalized, kFailed };

struct RelocalizationResult {
  geometry::Pose2 pose;  // of the last buffered scan, floor frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // of the refinement (world frame)
  double score = 0.0;        // refined mean score
  double best_other = 0.0;   // best correlative score of a pose clearly elsewhere
  double own = 0.0;          // correlative score of the estimate in the same search
  int filter_runs = 0;       // filters started (restarts + 1)
  int candidates = 0;        // converged estimates checked
  std::string last_problem;  // why the last candidate was refused
};

class GlobalRelocalizer {
 public:
  // The floor's map is rendered from every node of `graph`; `matcher_options` and
  // `match_field` are those of the front end's loop closures.
  GlobalRelocalizer(const floor::FloorGraph& graph, GlobalRelocalizationOptions options,
                    ScanMatcherOptions matcher_options, const grid::LikelihoodFieldOptions& match_field,
                    double max_insert_range);
  ~GlobalRelocalizer();

  // Buffers the scan (with the odometry pose at its stamp) and advances the filter.
  RelocalizationStatus add(const sensor::LaserScan& scan, const geometry::Pose2& odometry);
  // End of input: checks the filter's current estimate once more (when enough scans were
  // fed) instead of waiting for convergence. True when that localised the robot.
  bool decideNow();
  RelocalizationStatus status() const { return status_; }
  // The points a check uses: the last `refine_scans` fed scans placed by odometry in the
  // frame of the last one (empty before the first fed scan).
  std::vector<Eigen::Vector2d> recentPoints() const;
  // The best correlative score of `points` (in one robot frame) anywhere on this floor's
  // map, at any heading: the uniqueness search of a check, for points from elsewhere (is
  // this floor also a fit for scans another floor localised?).
  double bestFitAnywhere(const std::vector<Eigen::Vector2d>& points) const;
  const GlobalRelocalizationOptions& options() const { return options_; }
  const RelocalizationResult& result() const { return result_; }

  struct Buffered {
    sensor::LaserScan scan;
    geometry::Pose2 odometry;
  };
  const std::vector<Buffered>& buffer() const { return buffer_; }

 private:
  struct Impl;
  bool checkCandidate(const geometry::Pose2& estimate);
  struct Found {
    geometry::Pose2 pose;
    double score;
  };
  std::vector<Found> searchWholeMap(const std::vector<Eigen::Vector2d>& sparse) const;

  std::unique_ptr<Impl> impl_;
  GlobalRelocalizationOptions options_;
  std::vector<Buffered> buffer_;
  std::vector<std::size_t> fed_;  // buffer indices fed to the filter (all runs)
  RelocalizationStatus status_ = RelocalizationStatus::kSearching;
  RelocalizationResult result_;
};

}  // namespace storey::mapping
