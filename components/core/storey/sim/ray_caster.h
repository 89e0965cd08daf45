// Exact ray casting against line segments, accelerated by a uniform grid: a ray walks the
// cells it crosses (Amanatides-Woo) and tests only the segments registered in them.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "storey/sim/building.h"

namespace storey::sim {

class RayCaster {
 public:
  explicit RayCaster(std::vector<Segment> segments, double cell_size = 1.0);

  // Distance along the unit direction `dir` from `origin` to the first segment hit, or
  // +infinity when nothing lies within `max_range`.
  double cast(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir, double max_range) const;
  // The same by testing every segment (reference for tests).
  double castBruteForce(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir,
                        double max_range) const;
  const std::vector<Segment>& segments() const { return segments_; }

 private:
  double hit(std::uint32_t index, const Eigen::Vector2d& origin, const Eigen::Vector2d& dir) const;

  std::vector<Segment> segments_;
  double cell_ = 1.0;
  Eigen::Vector2d min_ = Eigen::Vector2d::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<std::uint32_t> cell_start_;  // CSR layout: cell -> range in cell_items_
  std::vector<std::uint32_t> cell_items_;
};

}  // namespace storey::sim
