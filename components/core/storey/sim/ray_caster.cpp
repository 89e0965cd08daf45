#include "storey/sim/ray_caster.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

RayCaster::RayCaster(std::vector<Segment> segments, double cell_size)
    : segments_(std::move(segments)), cell_(cell_size) {
  if (segments_.empty()) return;
  Eigen::Vector2d lo = segments_[0].a, hi = segments_[0].a;
  for (const auto& s : segments_) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b);
    hi = hi.cwiseMax(s.a).cwiseMax(s.b);
  }
  min_ = lo - Eigen::Vector2d::Constant(cell_);
  nx_ = static_cast<int>(std::ceil((hi.x() - min_.x()) / cell_)) + 1;
  ny_ = static_cast<int>(std::ceil((hi.y() - min_.y()) / cell_)) + 1;
  // Two passes (count, fill) into a compressed layout: cache friendly and no per-cell vectors.
  const double half_diagonal = cell_ * std::sqrt(0.5) + 1e-9;
  std::vector<std::uint32_t> counts(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  const auto forCells = [&](const Segment& s, auto&& visit) {
    const Eigen::Vector2d a = (s.a.cwiseMin(s.b) - min_) / cell_;
    const Eigen::Vector2d b = (s.a.cwiseMax(s.b) - min_) / cell_;
    for (int y = std::max(0, static_cast<int>(a.y()));
         y <= std::min(ny_ - 1, static_cast<int>(b.y())); ++y)
      for (int x = std::max(0, static_cast<int>(a.x()));
           x <= std::min(nx_ - 1, static_cast<int>(b.x())); ++x) {
        const Eigen::Vector2d center = min_ + Eigen::Vector2d(x + 0.5, y + 0.5) * cell_;
        if (pointSegmentDistance(center, s) <= half_diagonal) visit(y * nx_ + x);
      }
  };
  for (const auto& s : segments_) forCells(s, [&](int c) { ++counts[c + 1]; });
  for (std::size_t i = 1; i < counts.size(); ++i) counts[i] += counts[i - 1];
  cell_start_ = counts;
  cell_items_.resize(counts.back());
  std::vector<std::uint32_t> fill(counts.begin(), counts.end() - 1);
  for (std::uint32_t i = 0; i < segments_.size(); ++i)
    forCells(segments_[i], [&](int c) { cell_items_[fill[c]++] = i; });
}

double RayCaster::hit(std::uint32_t index, const Eigen::Vector2d& origin,
                      const Eigen::Vector2d& dir) const {
  const Segment& s = segments_[index];
  const Eigen::Vector2d e = s.b - s.a;
  const double denom = cross(dir, e);
  if (denom == 0.0) return kInf;  // parallel: a grazing ray does not return
  const Eigen::Vector2d w = s.a - origin;
  const double t = cross(w, e) / denom;
  const double u = cross(w, dir) / denom;
  if (t < 0.0 || u < 0.0 || u > 1.0) return kInf;
  return t;
}

double RayCaster::castBruteForce(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir,
                                 double max_range) const {
  double best = kInf;
  for (std::uint32_t i = 0; i < segments_.size(); ++i) best = std::min(best, hit(i, origin, dir));
  return best <= max_range ? best : kInf;
}

double RayCaster::cast(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir,
                       double max_range) const {
  if (segments_.empty()) return kInf;
  const Eigen::Vector2d g = (origin - min_) / cell_;
  int x = static_cast<int>(std::floor(g.x()));
  int y = static_cast<int>(std::floor(g.y()));
  if (x < 0 || y < 0 || x >= nx_ || y >= ny_) return castBruteForce(origin, dir, max_range);
  const int step_x = dir.x() > 0 ? 1 : -1;
  const int step_y = dir.y() > 0 ? 1 : -1;
  const double delta_x = dir.x() != 0.0 ? cell_ / std::abs(dir.x()) : kInf;
  const double delta_y = dir.y() != 0.0 ? cell_ / std::abs(dir.y()) : kInf;
  double next_x = dir.x() != 0.0
                      ? ((step_x > 0 ? x + 1 - g.x() : g.x() - x) * cell_) / std::abs(dir.x())
                      : kInf;
  double next_y = dir.y() != 0.0
                      ? ((step_y > 0 ? y + 1 - g.y() : g.y() - y) * cell_) / std::abs(dir.y())
                      : kInf;
  double best = kInf;
  while (true) {
    const int c = y * nx_ + x;
    for (std::uint32_t k = cell_start_[c]; k < cell_start_[c + 1]; ++k)
      best = std::min(best, hit(cell_items_[k], origin, dir));
    const double cell_exit = std::min(next_x, next_y);
    // A hit before this cell's exit cannot be beaten by a segment in a later cell.
    if (best <= cell_exit || cell_exit > max_range) break;
    if (next_x < next_y) {
      x += step_x;
      next_x += delta_x;
      if (x < 0 || x >= nx_) break;
    } else {
      y += step_y;
      next_y += delta_y;
      if (y < 0 || y >= ny_) break;
    }
  }
  return best <= max_range ? best : kInf;
}

}  // namespace storey::sim
