#include "storey/grid/point_map.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::grid {

PointMap::PointMap(const std::vector<Eigen::Vector2d>& points, double cell_size, double normal_radius) {
  if (points.empty() || !(cell_size > 0.0)) return;
  Eigen::Vector2d lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  frame_.resolution = cell_size;
  frame_.origin_x = lo.x() - cell_size;
  frame_.origin_y = lo.y() - cell_size;
  frame_.width = static_cast<int>(std::ceil((hi.x() - lo.x()) / cell_size)) + 3;
  frame_.height = static_cast<int>(std::ceil((hi.y() - lo.y()) / cell_size)) + 3;
  index_.assign(frame_.cellCount(), -1);
  std::vector<int> counts;
  for (const auto& p : points) {
    const Eigen::Vector2i c = frame_.cellOf(p);
    int& slot = index_[frame_.index(c.x(), c.y())];
    if (slot < 0) {
      slot = static_cast<int>(cells_.size());
      cells_.emplace_back();
      counts.push_back(0);
    }
    cells_[slot].mean += p;
    ++counts[slot];
  }
  for (std::size_t i = 0; i < cells_.size(); ++i) cells_[i].mean /= counts[i];

  const int ring = std::max(1, static_cast<int>(std::ceil(normal_radius / cell_size)));
  const double r2 = normal_radius * normal_radius;
  for (auto& cell : cells_) {
    const Eigen::Vector2i c = frame_.cellOf(cell.mean);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    int n = 0;
    for (int dy = -ring; dy <= ring; ++dy)
      for (int dx = -ring; dx <= ring; ++dx) {
        if (!frame_.contains(c.x() + dx, c.y() + dy)) continue;
        const int k = index_[frame_.index(c.x() + dx, c.y() + dy)];
        if (k < 0) continue;
        const Eigen::Vector2d& m = cells_[k].mean;
        if ((m - cell.mean).squaredNorm() > r2) continue;
        sum += m;
        scatter += m * m.transpose();
        ++n;
      }
    if (n < 3) continue;
    const Eigen::Vector2d mean = sum / n;
    scatter = scatter / n - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(scatter);
    // Line-like: one dominant direction (corners and clutter keep no normal).
    if (eig.eigenvalues()(1) <= 0.0 || eig.eigenvalues()(0) > 0.05 * eig.eigenvalues()(1)) continue;
    cell.normal = eig.eigenvectors().col(0);
  }
}

const PointMap::Cell* PointMap::nearest(const Eigen::Vector2d& q, double max_distance) const {
  if (cells_.empty()) return nullptr;
  const Eigen::Vector2i c = frame_.cellOf(q);
  const int ring = static_cast<int>(std::ceil(max_distance / frame_.resolution));
  const int x0 = std::max(0, c.x() - ring), x1 = std::min(frame_.width - 1, c.x() + ring);
  const int y0 = std::max(0, c.y() - ring), y1 = std::min(frame_.height - 1, c.y() + ring);
  double best = max_distance * max_distance;
  const Cell* found = nullptr;
  for (int y = y0; y <= y1; ++y) {
    const int* row = &index_[frame_.index(0, y)];
    for (int x = x0; x <= x1; ++x) {
      if (row[x] < 0) continue;
      const Cell& cell = cells_[row[x]];
      const double d2 = (cell.mean - q).squaredNorm();
      if (d2 <= best) {
        best = d2;
        found = &cell;
      }
    }
  }
  return found;
}

namespace {

// r = n·e for e = T p − m, with dq/dθ of T p: the pose's sine and cosine are computed once
// per iteration by the caller, not once per point.
double lineResidual(const PointMap::Cell& cell, const Eigen::Vector2d& e, const Eigen::Vector2d& dq_dtheta,
                    Eigen::RowVector3d* jacobian) {
  if (jacobian) *jacobian << cell.normal.x(), cell.normal.y(), cell.normal.dot(dq_dtheta);
  return cell.normal.dot(e);
}

}  // namespace

double pointToLineResidual(const PointMap::Cell& cell, const geometry::Pose2& pose, const Eigen::Vector2d& point,
                           Eigen::RowVector3d* jacobian) {
  const double c = std::cos(pose.theta()), s = std::sin(pose.theta());
  const Eigen::Vector2d q(c * point.x() - s * point.y() + pose.x(), s * point.x() + c * point.y() + pose.y());
  const Eigen::Vector2d dq_dtheta(-s * point.x() - c * point.y(), c * point.x() - s * point.y());
  return lineResidual(cell, q - cell.mean, dq_dtheta, jacobian);
}

PointAlignment alignToPoints(const PointMap& map, const std::vector<Eigen::Vector2d>& points,
                             const geometry::Pose2& initial, const PointAlignmentOptions& o) {
  const double c2 = o.robust_distance * o.robust_distance;
  const double max_along = map.cellSize();
  PointAlignment out;
  Eigen::Vector3d b;
  auto linearise = [&](const geometry::Pose2& pose) {
    const double c = std::cos(pose.theta()), s = std::sin(pose.theta());
    out.information.setZero();
    b.setZero();
    out.weighted_r2 = out.weight_sum = 0.0;
    for (const auto& p : points) {
      const Eigen::Vector2d q(c * p.x() - s * p.y() + pose.x(), s * p.x() + c * p.y() + pose.y());
      const PointMap::Cell* m = map.nearest(q, o.max_correspondence_distance);
      if (!m) continue;
      // Lines only: a point paired with a corner or clutter, or beyond the end of the
      // map's line (a wall the map has not seen that far yet), would pull the pose
      // towards where the map stops.
      if (m->normal.isZero()) continue;
      const Eigen::Vector2d e = q - m->mean;
      if (std::abs(m->normal.x() * e.y() - m->normal.y() * e.x()) > max_along) continue;
      const Eigen::Vector2d dq_dtheta(-s * p.x() - c * p.y(), c * p.x() - s * p.y());
      Eigen::RowVector3d j;
      const double r = lineResidual(*m, e, dq_dtheta, &j);
      const double w = 1.0 / (1.0 + r * r / c2);
      out.information += w * j.transpose() * j;
      b += w * j.transpose() * r;
      out.weighted_r2 += w * r * r;
      out.weight_sum += w;
    }
  };
  const double wt = o.translation_prior_weight, wr = o.rotation_prior_weight;
  geometry::Pose2 pose = initial;
  for (int it = 0; it < o.max_iterations; ++it) {
    linearise(pose);
    if (out.weight_sum < 3.0) break;
    const Eigen::Vector3d d(pose.x() - initial.x(), pose.y() - initial.y(),
                            geometry::angleDiff(pose.theta(), initial.theta()));
    Eigen::Matrix3d h = out.information;
    h.diagonal() += Eigen::Vector3d(wt, wt, wr) + Eigen::Vector3d::Constant(1e-9);
    const Eigen::Vector3d delta = h.ldlt().solve(-(b + Eigen::Vector3d(wt * d.x(), wt * d.y(), wr * d.z())));
    if (!delta.allFinite()) break;
    pose = geometry::Pose2(pose.x() + delta.x(), pose.y() + delta.y(), pose.theta() + delta.z());
    if (delta.head<2>().norm() + std::abs(delta.z()) < 1e-6) break;
  }
  linearise(pose);
  out.pose = pose;
  return out;
}

Eigen::Matrix3d withoutNormalNoise(const Eigen::Matrix3d& information, double tilt_stddev) {
  if (tilt_stddev <= 0.0) return information;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(information.topLeftCorner<2, 2>());
  const double weak = eigen.eigenvalues()(0), strong = eigen.eigenvalues()(1);
  if (!(weak > 0.0)) return information;
  const double kept = std::max(0.0, weak - tilt_stddev * tilt_stddev * strong) / weak;
  if (kept >= 1.0) return information;
  // Scale the weak direction (its row and column, so the result stays positive
  // semi-definite) in the eigenbasis of the translation block.
  Eigen::Matrix3d basis = Eigen::Matrix3d::Identity();
  basis.topLeftCorner<2, 2>() = eigen.eigenvectors();
  Eigen::Matrix3d rotated = basis.transpose() * information * basis;
  const double f = std::sqrt(kept);
  rotated.row(0) *= f;
  rotated.col(0) *= f;
  return basis * rotated * basis.transpose();
}

TranslationConditioning translationConditioning(const Eigen::Matrix3d& information,
                                                const Eigen::Vector2d& centre_offset) {
  TranslationConditioning c;
  // A small turn δθ about c moves the pose's translation by δθ·J(t − c) (J the 90° turn),
  // so (δt, δθ) = A (δt_c, δθ) and the information about (δt_c, δθ) is Aᵀ I A.
  Eigen::Matrix3d a = Eigen::Matrix3d::Identity();
  a(0, 2) = -centre_offset.y();
  a(1, 2) = centre_offset.x();
  const Eigen::Matrix3d local = a.transpose() * information * a;
  Eigen::Matrix2d block = local.topLeftCorner<2, 2>();
  if (local(2, 2) > 0.0) block -= local.topRightCorner<2, 1>() * local.bottomLeftCorner<1, 2>() / local(2, 2);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(block);
  const double weak = eigen.eigenvalues()(0), strong = eigen.eigenvalues()(1);
  c.strong = strong;
  c.weak_direction = eigen.eigenvectors().col(0);
  c.ratio = strong > 0.0 ? std::max(0.0, weak) / strong : 0.0;
  return c;
}

}  // namespace storey::grid
