// The likelihood-field sensor model of Probabilistic Robotics (Thrun et al., ch. 6.4):
// a beam endpoint at distance d from the nearest obstacle has probability
// z_hit * N(d; 0, sigma_hit) + z_rand / range_max. Precomputed per cell from an exact
// distance transform of the map's occupied cells.
#pragma once

#include <vector>

#include "storey/grid/grid2.h"
#include "storey/grid/occupancy_grid.h"

namespace storey::grid {

struct LikelihoodFieldOptions {
  double sigma_hit = 0.1;     // metres
  double z_hit = 0.9;
  double z_rand = 0.1;
  double max_distance = 1.0;  // distances are capped here (metres)
  double range_max = 30.0;    // for the uniform z_rand term
  double occupied_threshold = 0.65;
};

class LikelihoodField {
 public:
  // The scan matcher reads distance and score only; particle weighting reads the
  // log-likelihood. Leaving a table out saves a third of the field's time and memory.
  enum class LogLikelihoodTable { kBuild, kSkip };

  LikelihoodField() = default;
  LikelihoodField(const OccupancyGrid& grid, const LikelihoodFieldOptions& options,
                  LogLikelihoodTable table = LogLikelihoodTable::kBuild);
  // From an explicit obstacle mask (1 = obstacle) over `frame`.
  LikelihoodField(const GridFrame& frame, const std::vector<std::uint8_t>& obstacles,
                  const LikelihoodFieldOptions& options,
                  LogLikelihoodTable table = LogLikelihoodTable::kBuild);

  const GridFrame& frame() const { return distance_.frame; }
  const Grid2<float>& distance() const { return distance_; }
  // log p(endpoint) per cell, for particle weighting by table lookup (empty when skipped).
  const Grid2<float>& logLikelihood() const { return log_likelihood_; }
  // Smooth score exp(-d^2 / 2 sigma^2) in [0, 1] per cell, for gradient-based matching.
  const Grid2<float>& score() const { return score_; }
  const LikelihoodFieldOptions& options() const { return options_; }

  // log p of an endpoint at a world point (nearest cell); outside the map: max distance.
  // Needs the log-likelihood table.
  float logLikelihoodAt(const Eigen::Vector2d& p) const;
  // Bilinearly interpolated score and its gradient (per metre) at a world point.
  double interpolatedScore(const Eigen::Vector2d& p, Eigen::Vector2d* gradient = nullptr) const;
  float outsideLogLikelihood() const { return outside_log_likelihood_; }

 private:
  void build(const std::vector<std::uint8_t>& obstacles, LogLikelihoodTable table);

  LikelihoodFieldOptions options_;
  Grid2<float> distance_;
  Grid2<float> log_likelihood_;
  Grid2<float> score_;
  float outside_log_likelihood_ = 0.0f;
};

// Obstacle mask of a grid (cells above the occupied threshold).
std::vector<std::uint8_t> obstacleMask(const OccupancyGrid& grid, double occupied_threshold);

// Sliding-window max: level k's cell (x, y) holds the max of the base over
// [x, x + 2^k) x [y, y + 2^k). Level 0 is the base. Used to bound scores in
// branch-and-bound correlative scan matching.
std::vector<Grid2<float>> maxPyramid(const Grid2<float>& base, int levels);

}  // namespace storey::grid
