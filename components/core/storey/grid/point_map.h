// The points of a map's scans for sub-cell matching: the returns of several scans,
// averaged per cell (which also averages their range noise), with each cell's surface
// normal from its neighbours. An occupancy grid puts a wall at cell centres, so a match
// against its likelihood field cannot place the wall better than a cell (0.05 m, i.e.
// about 0.5° of heading over a 5 m scan); point-to-line distances to these means can.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/grid/grid2.h"

namespace storey::grid {

class PointMap {
 public:
  struct Cell {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    Eigen::Vector2d normal = Eigen::Vector2d::Zero();  // zero where not line-like
  };

  PointMap() = default;
  // `points` in the map frame; `cell_size` the averaging cell; normals from the cell
  // means within `normal_radius`.
  PointMap(const std::vector<Eigen::Vector2d>& points, double cell_size, double normal_radius);

  bool empty() const { return cells_.empty(); }
  std::size_t size() const { return cells_.size(); }
  double cellSize() const { return frame_.resolution; }
  const std::vector<Cell>& cells() const { return cells_; }
  // The cell whose mean is nearest to `q` within `max_distance`, or nullptr.
  const Cell* nearest(const Eigen::Vector2d& q, double max_distance) const;

 private:
  grid::GridFrame frame_;
  std::vector<int> index_;  // per grid cell: index into cells_, or -1
  std::vector<Cell> cells_;
};

// r = n·(T p − m) of a point p paired with a line cell (mean m, normal n) and its 1×3
// Jacobian with respect to T = (x, y, θ). Exposed for the numeric-derivative test.
double pointToLineResidual(const PointMap::Cell& cell, const geometry::Pose2& pose, const Eigen::Vector2d& point,
                           Eigen::RowVector3d* jacobian);

struct PointAlignmentOptions {
  int max_iterations = 15;
  double max_correspondence_distance = 0.15;  // m, point to the nearest cell mean
  double robust_distance = 0.05;              // m, Cauchy width on the distances
  // Weak priors towards the initial pose (units of summed squared distance, m²): they
  // only matter in directions the points do not constrain.
  double translation_prior_weight = 1.0;
  double rotation_prior_weight = 1.0;
};

struct PointAlignment {
  geometry::Pose2 pose;
  // Σ w JᵀJ of the final residuals (without the priors), their Σ w r² and Σ w.
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  double weighted_r2 = 0.0;
  double weight_sum = 0.0;
};

// The pose T minimising Σ ρ(n·(T p − m)) over `points` (m the nearest cell mean, n its
// normal; points whose nearest cell is not on a line, or lies more than a cell along the
// line from them, are left out), by Gauss-Newton re-associating every iteration, from
// `initial`. The same problem whether T places one scan in a map (points in the robot
// frame) or one floor's scans on another's (points in the floor's frame).
PointAlignment alignToPoints(const PointMap& map, const std::vector<Eigen::Vector2d>& points,
                             const geometry::Pose2& initial, const PointAlignmentOptions& options);

// A match's information (x, y, θ) less what noisy normals make up: along the weaker
// translational direction, tilt_stddev² of the stronger one's eigenvalue is taken off
// (clamped at none) by scaling that direction's row and column, so the result stays
// positive semi-definite. (Its coupling to the heading goes with it: where all of it is
// taken off, the heading's marginal information grows by what the coupling cost.)
Eigen::Matrix3d withoutNormalNoise(const Eigen::Matrix3d& information, double tilt_stddev);

// How well point-to-line information pins a position: the translational block with the
// heading marginalised out, its eigenvalues weak ≤ strong and the weak eigenvector.
// ratio = weak / strong (0 when the block is not positive). alignToPoints' information
// turns the pose about its own translation t; the position that matters is usually where
// the points are (c): centre_offset = t − c re-expresses it there first (else a heading
// uncertainty far from the points would read as a translational one).
struct TranslationConditioning {
  double ratio = 0.0;
  double strong = 0.0;
  Eigen::Vector2d weak_direction = Eigen::Vector2d::UnitX();
};
TranslationConditioning translationConditioning(const Eigen::Matrix3d& information,
                                                const Eigen::Vector2d& centre_offset = Eigen::Vector2d::Zero());

}  // namespace storey::grid
