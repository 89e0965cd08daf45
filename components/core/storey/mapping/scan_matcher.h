// Scan-to-map matching in two stages. A correlative search (branch and bound over a
// max-pyramid of the likelihood field's score, as in Olson 2009 and Hess et al. 2016)
// finds the best (x, y, θ) within a window around a prediction, exactly at the grid's
// resolution; Gauss-Newton then refines it below a cell on the likelihood field's
// bilinearly interpolated obstacle distance (robust Cauchy weights). The score itself is
// flat at its peak (exp(-d²/2σ²)), which makes a poorly conditioned refinement; the
// distance it is computed from is not. The covariance is σ²(JᵀWJ)⁻¹ with point-to-line
// Jacobians from the scan's own surface normals (Censi 2007), so a featureless direction
// (a corridor's axis) gets a large variance instead of a confident guess.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/geometry/pose2.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/grid/point_map.h"

namespace storey::mapping {

struct ScanMatcherOptions {
  // Correlative search window around the prediction (half widths).
  double linear_window = 0.3;    // m
  double angular_window = 0.35;  // rad
  double angular_step = 0.0;     // rad; 0: from the resolution and the scan's extent...
  double min_angular_step = 0.004;  // rad; ...but no finer (the refinement does the rest)
  // Scores below this (mean per-point score in [0, 1]) are no match.
  double min_score = 0.35;
  // The most point lookups (candidates bounded or scored × the scan's points) one
  // correlative search may make, so a search costs bounded time however weakly it prunes
  // (0: unbounded). A search that reaches it stops: no match, and no claim that there is
  // none elsewhere (MatchResult::exhausted).
  double max_lookups = 0.0;
  // Small penalties on the distance from the prediction: break ties in featureless
  // directions towards the prediction rather than to an arbitrary end of the window.
  double translation_penalty = 0.02;  // score per metre
  double rotation_penalty = 0.02;     // score per radian
  // Gauss-Newton refinement.
  int max_iterations = 15;
  // Weak priors pulling the refinement towards the correlative result (in units of the
  // summed squared point distance, m²): they only matter where the scan says nothing.
  double translation_prior_weight = 1.0;
  double rotation_prior_weight = 1.0;
  double robust_distance = 0.1;  // m, Cauchy width on point-to-obstacle distances
  // Where the target carries its scans' points (MatchTarget::setPoints), the refinement
  // uses point-to-line distances to them instead of the likelihood field (sub-cell). The
  // front end refines tracking on points and loop closures on the field.
  bool point_refinement = false;
  double max_correspondence_distance = 0.15;  // m, scan point to the map's nearest mean
  double point_robust_distance = 0.05;        // m, Cauchy width on point-to-line distances
  // The information of a point-refined match comes from the map's normals at the paired points.
  double min_point_stddev = 0.02;  // m, floor of the per-point noise in the covariance
  // Normals are fitted to noisy neighbours, so they tilt by about this much: a straight
  // corridor's normals then show a sliver of information along its axis that is their
  // noise (a translational eigenvalue below tilt² of the other, 1e-4 in the featureless
  // scenario). That much of the strongest direction's information is taken off the
  // weakest, so such a corridor gets none along its axis.
  double normal_tilt_stddev = 0.0;  // rad (0: off; the front end's laser model sets it)
  double normal_radius = 0.3;      // m, neighbourhood of a point's surface normal
  // Covariance: σ² (JᵀJ)⁻¹ times this factor (neighbouring beams are not independent),
  // then floored by the minimum standard deviations.
  double covariance_scale = 10.0;
  double min_translation_stddev = 0.01;  // m
  double min_rotation_stddev = 0.003;    // rad
  double max_translation_stddev = 10.0;  // m, regularises a direction with no information
  double max_rotation_stddev = 1.0;      // rad
  // Points closer than this to an already kept point are dropped (even weighting).
  double point_filter_distance = 0.05;  // m
  int min_points = 20;
};
// A map prepared for matching: its likelihood field and the max pyramid of the score.
class MatchTarget {
 public:
  MatchTarget() = default;
  MatchTarget(const grid::OccupancyGrid& grid, const grid::LikelihoodFieldOptions& options,
              int pyramid_levels = 7);
  // The room a target's grid needs beyond its returns (OccupancyGridOptions::growth_margin):
  // the field's cap (beyond it the score is ~0, as outside the grid) plus the pyramid's
  // widest block (a block starting outside the grid reads 0 there, which must not hide the
  // cells it covers inside). Fields and pyramid then cost a fraction of the default room.
  static double gridMargin(const grid::LikelihoodFieldOptions& options, double resolution, int pyramid_levels);
  bool empty() const { return field_.frame().width == 0; }
  const grid::LikelihoodField& field() const { return field_; }
  // The map's scan points (same frame) for the sub-cell refinement; none by default.
  void setPoints(grid::PointMap points) { points_ = std::move(points); }
  const grid::PointMap& points() const { return points_; }
  // Level k's cell (x, y) holds the max score over [x, x + 2^k) x [y, y + 2^k); level 0
  // is the field's score itself (not copied).
  int pyramidLevels() const { return 1 + static_cast<int>(coarse_levels_.size()); }
  const grid::Grid2<float>& pyramidLevel(int k) const {
    return k == 0 ? field_.score() : coarse_levels_[static_cast<std::size_t>(k - 1)];
  }

 private:
  grid::LikelihoodField field_;
  std::vector<grid::Grid2<float>> coarse_levels_;  // levels 1, 2, ...
  grid::PointMap points_;
};

struct MatchResult {
  bool success = false;
  std::string problem;           // why not, when !success
  geometry::Pose2 pose;          // robot pose in the map frame
  double correlative_score = 0;  // mean score of the best grid candidate
  double score = 0;              // mean interpolated score after refinement
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  int points = 0;
  // Refined on the target's points: the weight of the point-to-line pairs (-1: refined on
  // the likelihood field).
  double line_weight = -1.0;
  long candidates_scored = 0;  // leaves and bounds evaluated (for speed figures)
  bool exhausted = false;      // the search stopped at max_lookups before it was complete
};

// Bilinearly interpolated obstacle distance of the field (capped at its max_distance) and
// its gradient.
double interpolatedDistance(const grid::LikelihoodField& field, const Eigen::Vector2d& p,
                            Eigen::Vector2d* gradient = nullptr);

// Mean interpolated score of robot-frame `points` at `pose` (0 for no points): the
// matcher's score of a pose, as its gates read it.
double meanScore(const grid::LikelihoodField& field, const std::vector<Eigen::Vector2d>& points,
                 const geometry::Pose2& pose);

// Per-point residual r = D(T(ξ)·p), D the interpolated obstacle distance, of the refinement and its 1×3 Jacobian with respect
// to ξ = (x, y, θ) of the robot pose. Exposed for the numeric-derivative test.
double pointResidual(const grid::LikelihoodField& field, const geometry::Pose2& pose,
                     const Eigen::Vector2d& point, Eigen::RowVector3d* jacobian);

// Unit surface normals of points given in scan order, from their neighbours within
// `radius` (zero where the neighbourhood is not line-like).
std::vector<Eigen::Vector2d> pointNormals(const std::vector<Eigen::Vector2d>& points, double radius);

// Drops points within `distance` of a previously kept point (greedy, order-preserving).
std::vector<Eigen::Vector2d> filterPoints(const std::vector<Eigen::Vector2d>& points,
                                          double distance);

class ScanMatcher {
 public:
  explicit ScanMatcher(ScanMatcherOptions options = {});
  const ScanMatcherOptions& options() const { return options_; }

  // Matches robot-frame points (already filtered or not) against the target around
  // `prediction`. Window half widths override the options when positive.
  MatchResult match(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                    const geometry::Pose2& prediction, double linear_window = -1.0,
                    double angular_window = -1.0) const;

  // The correlative stage alone (best grid candidate); score < min_score means none.
  MatchResult correlativeSearch(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                                const geometry::Pose2& prediction, double linear_window,
                                double angular_window) const;
  // The same search with every position within `radius` of `excluded` left out: the best
  // match elsewhere in the window scoring above `min_score` (and the options' min_score),
  // which tells a unique match from one of several alike (a corridor's repeating doors).
  // success false when there is none; a high min_score lets the search prune early.
  MatchResult bestElsewhere(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                            const geometry::Pose2& prediction, double linear_window,
                            double angular_window, const Eigen::Vector2d& excluded, double radius,
                            double min_score = 0.0) const;
  // The refinement alone, from `initial`; fills pose, score and covariance.
  MatchResult refine(const grid::LikelihoodField& field, const std::vector<Eigen::Vector2d>& points,
                     const geometry::Pose2& initial) const;
  // The refinement on the target's points (point-to-line, re-associated each iteration);
  // the score is still the likelihood field's, so gates mean the same either way.
  MatchResult refineOnPoints(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                             const geometry::Pose2& initial) const;

 private:
  ScanMatcherOptions options_;
};

}  // namespace storey::mapping
