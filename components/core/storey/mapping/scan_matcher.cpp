#include "storey/mapping/scan_matcher.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include "storey/common/log.h"

namespace storey::mapping {

using geometry::Pose2;

double MatchTarget::gridMargin(const grid::LikelihoodFieldOptions& options, double resolution,
                               int pyramid_levels) {
  return options.max_distance + ((1 << (std::max(1, pyramid_levels) - 1)) + 1) * resolution;
}

MatchTarget::MatchTarget(const grid::OccupancyGrid& grid, const grid::LikelihoodFieldOptions& options,
                         int pyramid_levels)
    : field_(grid, options, grid::LikelihoodField::LogLikelihoodTable::kSkip) {
  // Same content as grid::maxPyramid, built by doubling: level k's window is four of level
  // k-1's (two by two), so each level is one pass of plain max (no deques). Beyond the
  // grid the score is 0, the least it can be, so blocks there simply leave it out.
  const grid::GridFrame& f = field_.score().frame;
  coarse_levels_.reserve(static_cast<std::size_t>(std::max(0, pyramid_levels - 1)));
  for (int level = 1; level < std::max(1, pyramid_levels); ++level) {
    const grid::Grid2<float>& prev = pyramidLevel(level - 1);
    const int half = 1 << (level - 1);
    const int split = std::max(0, f.width - half);  // x + half is inside below this
    grid::Grid2<float> next(f, grid::Unfilled{});   // every row written below
    // Rows as Eigen arrays: the compiler cannot tell that `out` does not alias the previous
    // level, so a plain loop stays scalar; Eigen's packet max does four or more at once.
    using ConstRow = Eigen::Map<const Eigen::ArrayXf>;
    using Row = Eigen::Map<Eigen::ArrayXf>;
    const int tail = f.width - split;
    for (int y = 0; y < f.height; ++y) {
      const float* a = &prev.data[f.index(0, y)];
      float* out = &next.data[f.index(0, y)];
      if (y + half < f.height) {
        const float* b = &prev.data[f.index(0, y + half)];
        Row(out, split) = ConstRow(a, split)
                              .max(ConstRow(a + half, split))
                              .max(ConstRow(b, split).max(ConstRow(b + half, split)));
        Row(out + split, tail) = ConstRow(a + split, tail).max(ConstRow(b + split, tail));
      } else {
        Row(out, split) = ConstRow(a, split).max(ConstRow(a + half, split));
        Row(out + split, tail) = ConstRow(a + split, tail);
      }
    }
    coarse_levels_.push_back(std::move(next));
  }
}

double interpolatedDistance(const grid::LikelihoodField& field, const Eigen::Vector2d& p,
                            Eigen::Vector2d* gradient) {
  const grid::Grid2<float>& dist = field.distance();
  const grid::GridFrame& f = dist.frame;
  const float outside = static_cast<float>(field.options().max_distance);
  // Cell centres sit at integer + 0.5 in continuous cell coordinates.
  const Eigen::Vector2d c = f.continuousCellOf(p) - Eigen::Vector2d(0.5, 0.5);
  const int x0 = static_cast<int>(std::floor(c.x())), y0 = static_cast<int>(std::floor(c.y()));
  const double fx = c.x() - x0, fy = c.y() - y0;
  const double v00 = dist.valueOr(x0, y0, outside), v10 = dist.valueOr(x0 + 1, y0, outside);
  const double v01 = dist.valueOr(x0, y0 + 1, outside), v11 = dist.valueOr(x0 + 1, y0 + 1, outside);
  if (gradient) {
    const double inv_res = 1.0 / f.resolution;
    gradient->x() = ((v10 - v00) * (1 - fy) + (v11 - v01) * fy) * inv_res;
    gradient->y() = ((v01 - v00) * (1 - fx) + (v11 - v10) * fx) * inv_res;
  }
  return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy;
}

double pointResidual(const grid::LikelihoodField& field, const Pose2& pose, const Eigen::Vector2d& point,
                     Eigen::RowVector3d* jacobian) {
  const double c = std::cos(pose.theta()), s = std::sin(pose.theta());
  const Eigen::Vector2d q(c * point.x() - s * point.y() + pose.x(), s * point.x() + c * point.y() + pose.y());
  Eigen::Vector2d g;
  const double d = interpolatedDistance(field, q, jacobian ? &g : nullptr);
  if (jacobian) {
    const Eigen::Vector2d dq_dtheta(-s * point.x() - c * point.y(), c * point.x() - s * point.y());
    *jacobian << g.x(), g.y(), g.dot(dq_dtheta);
  }
  return d;
}

std::vector<Eigen::Vector2d> filterPoints(const std::vector<Eigen::Vector2d>& points, double distance) {
  if (distance <= 0.0) return points;
  // Hash on a grid of cell size `distance`: a kept point blocks its neighbours within it.
  struct Hash {
    std::size_t operator()(const std::pair<long, long>& k) const {
      return std::hash<long>()(k.first * 73856093L ^ k.second * 19349663L);
    }
  };
  std::unordered_map<std::pair<long, long>, std::vector<int>, Hash> cells;
  std::vector<Eigen::Vector2d> kept;
  const double d2 = distance * distance;
  for (const auto& p : points) {
    const long cx = static_cast<long>(std::floor(p.x() / distance));
    const long cy = static_cast<long>(std::floor(p.y() / distance));
    bool near = false;
    for (long dx = -1; dx <= 1 && !near; ++dx)
      for (long dy = -1; dy <= 1 && !near; ++dy) {
        auto it = cells.find({cx + dx, cy + dy});
        if (it == cells.end()) continue;
        for (int k : it->second)
          if ((kept[k] - p).squaredNorm() < d2) {
            near = true;
            break;
          }
      }
    if (near) continue;
    cells[{cx, cy}].push_back(static_cast<int>(kept.size()));
    kept.push_back(p);
  }
  return kept;
}

std::vector<Eigen::Vector2d> pointNormals(const std::vector<Eigen::Vector2d>& points, double radius) {
  std::vector<Eigen::Vector2d> normals(points.size(), Eigen::Vector2d::Zero());
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Neighbours in scan order (points come in beam order) within the radius.
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    int count = 0;
    const std::size_t lo = i >= 3 ? i - 3 : 0, hi = std::min(points.size(), i + 4);
    for (std::size_t k = lo; k < hi; ++k) {
      if ((points[k] - points[i]).squaredNorm() > r2) continue;
      mean += points[k];
      scatter += points[k] * points[k].transpose();
      ++count;
    }
    if (count < 3) continue;
    mean /= count;
    scatter = scatter / count - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(scatter);
    // A line: one clearly dominant direction.
    if (eig.eigenvalues()(1) <= 0.0 || eig.eigenvalues()(0) > 0.1 * eig.eigenvalues()(1)) continue;
    normals[i] = eig.eigenvectors().col(0);
  }
  return normals;
}

ScanMatcher::ScanMatcher(ScanMatcherOptions options) : options_(options) {}

namespace {

// Weighted point-to-line pairs a point refinement needs.
constexpr double kMinLineWeight = 3.0;

// A disc of positions left out of the search, in cells relative to the prediction.
struct ExcludedDisc {
  double x = 0.0, y = 0.0, radius = 0.0;
  // Whether the block of cell offsets [x0, x1] x [y0, y1] lies wholly inside.
  bool covers(int x0, int x1, int y0, int y1) const {
    const double dx = std::max(std::abs(x0 - x), std::abs(x1 - x));
    const double dy = std::max(std::abs(y0 - y), std::abs(y1 - y));
    return dx * dx + dy * dy < radius * radius;
  }
};

struct Candidate {
  int angle = 0;  // index into the angle list
  int x = 0, y = 0;  // cell offsets of the node's lower corner
  int level = 0;
  double bound = 0.0;
};

// Lower bound of the Euclidean distance (in cells) from the origin to [x0, x1] x [y0, y1].
double rectDistance(int x0, int x1, int y0, int y1) {
  const double dx = x0 > 0 ? x0 : (x1 < 0 ? -x1 : 0);
  const double dy = y0 > 0 ? y0 : (y1 < 0 ? -y1 : 0);
  return std::sqrt(dx * dx + dy * dy);
}

// The scan's cells at one rotation, split by where the search's shifts can take them:
// cells inside the grid at every shift are summed by offset without a bounds check; cells
// outside at every shift score 0 and are left out; the rest are checked per shift.
struct RotatedCells {
  std::vector<std::ptrdiff_t> inside;  // cy * width + cx
  std::vector<Eigen::Vector2i> border;
  std::size_t count = 0;  // all the scan's cells, for the mean
};

// The search reads each cell shifted by -window to +window in x and y (a node's lower
// corner: the pyramid holds the max over its block).
RotatedCells rotatedCells(const std::vector<Eigen::Vector2i>& cells, const grid::GridFrame& f, int window) {
  RotatedCells r;
  r.count = cells.size();
  for (const Eigen::Vector2i& c : cells) {
    if (c.x() - window >= 0 && c.x() + window < f.width && c.y() - window >= 0 && c.y() + window < f.height)
      r.inside.push_back(static_cast<std::ptrdiff_t>(c.y()) * f.width + c.x());
    else if (c.x() + window >= 0 && c.x() - window < f.width && c.y() + window >= 0 && c.y() - window < f.height)
      r.border.push_back(c);
  }
  return r;
}

class BranchAndBound {
 public:
  BranchAndBound(const MatchTarget& target, const std::vector<RotatedCells>& rotations,
                 const std::vector<double>& angle_offsets, int window, const ScanMatcherOptions& o,
                 const ExcludedDisc* excluded)
      : target_(target), rotations_(rotations), angle_offsets_(angle_offsets), window_(window), o_(o),
        excluded_(excluded) {
    const grid::GridFrame& f = target.field().frame();
    res_ = f.resolution;
    width_ = f.width;
    height_ = f.height;
  }

  double bound(const Candidate& c) const {
    const grid::Grid2<float>& level = target_.pyramidLevel(c.level);
    const RotatedCells& r = rotations_[c.angle];
    const float* base = level.data.data() + (static_cast<std::ptrdiff_t>(c.y) * width_ + c.x);
    double sum = 0.0;
    for (const std::ptrdiff_t offset : r.inside) sum += base[offset];
    for (const auto& cell : r.border) sum += level.valueOr(cell.x() + c.x, cell.y() + c.y, 0.0f);
    const int size = (1 << c.level) - 1;
    const double dist = rectDistance(c.x, std::min(c.x + size, window_), c.y, std::min(c.y + size, window_));
    ++evaluated_;
    return sum / static_cast<double>(r.count) - o_.translation_penalty * dist * res_ -
           o_.rotation_penalty * std::abs(angle_offsets_[c.angle]);
  }

  // Depth first, best bound first, over nodes [begin, end); stops for good once
  // `max_evaluations` bounds have been computed.
  void search(Candidate* begin, Candidate* end) {
    if (exhausted_) return;
    if (max_evaluations_ > 0 && evaluated_ + (end - begin) > max_evaluations_) {
      exhausted_ = true;
      return;
    }
    for (Candidate* n = begin; n != end; ++n) n->bound = bound(*n);
    std::sort(begin, end, [](const Candidate& a, const Candidate& b) { return a.bound > b.bound; });
    for (const Candidate* n = begin; n != end; ++n) {
      if (n->bound <= best_score_) break;  // sorted: nothing after can beat the best
      if (excluded_) {
        const int size = (1 << n->level) - 1;
        if (excluded_->covers(n->x, std::min(n->x + size, window_), n->y, std::min(n->y + size, window_))) continue;
      }
      if (n->level == 0) {
        best_score_ = n->bound;
        best_ = *n;
        found_ = true;
        continue;
      }
      const int half = 1 << (n->level - 1);
      Candidate children[4];
      int count = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const Candidate c{n->angle, n->x + dx * half, n->y + dy * half, n->level - 1, 0.0};
          if (c.x > window_ || c.y > window_) continue;
          children[count++] = c;
        }
      search(children, children + count);
      if (exhausted_) return;
    }
  }

  double best_score_ = 0.0;
  Candidate best_;
  bool found_ = false;
  bool exhausted_ = false;
  long max_evaluations_ = 0;  // 0: unbounded
  mutable long evaluated_ = 0;

 private:
  const MatchTarget& target_;
  const std::vector<RotatedCells>& rotations_;
  const std::vector<double>& angle_offsets_;
  int window_;
  const ScanMatcherOptions& o_;
  const ExcludedDisc* excluded_;  // blocks wholly inside are left out (none when null)
  double res_ = 0.05;
  int width_ = 0, height_ = 0;
};


// The correlative search (branch and bound over the pyramid): the best candidate scoring
// above min_score, positions inside `excluded` left out.
MatchResult correlative(const ScanMatcherOptions& options, const MatchTarget& target,
                        const std::vector<Eigen::Vector2d>& points, const Pose2& prediction,
                        double linear_window, double angular_window, double min_score,
                        const ExcludedDisc* excluded) {
  MatchResult result;
  result.points = static_cast<int>(points.size());
  result.pose = prediction;
  if (target.empty()) {
    result.problem = "empty map";
    return result;
  }
  if (static_cast<int>(points.size()) < options.min_points) {
    result.problem = common::str("too few points (", points.size(), " < ", options.min_points, ")");
    return result;
  }
  const grid::GridFrame& frame = target.field().frame();
  const double res = frame.resolution;
  double max_range = 0.0;
  for (const auto& p : points) max_range = std::max(max_range, p.norm());
  double step = options.angular_step;
  if (step <= 0.0) {
    // The angle that moves the farthest point by one cell.
    step = std::acos(std::clamp(1.0 - res * res / (2.0 * max_range * max_range), -1.0, 1.0));
    step = std::max(step, options.min_angular_step);
  }
  const int num_angles = static_cast<int>(std::ceil(angular_window / step));
  const int window = static_cast<int>(std::ceil(linear_window / res));
  const int max_level = target.pyramidLevels() - 1;
  int level = 0;
  while ((1 << level) < 2 * window + 1 && level < max_level) ++level;
  const int top = 1 << level;
  std::vector<double> offsets;
  std::vector<RotatedCells> rotations;
  std::vector<Eigen::Vector2d> placed;
  std::vector<Eigen::Vector2i> cells(points.size());
  for (int a = -num_angles; a <= num_angles; ++a) {
    const double offset = a * step;
    offsets.push_back(offset);
    Pose2(prediction.x(), prediction.y(), prediction.theta() + offset).transformPoints(points, &placed);
    for (std::size_t i = 0; i < points.size(); ++i) cells[i] = frame.cellOf(placed[i]);
    rotations.push_back(rotatedCells(cells, frame, window));
  }

  BranchAndBound bb(target, rotations, offsets, window, options, excluded);
  bb.best_score_ = min_score;
  if (options.max_lookups > 0.0)
    bb.max_evaluations_ = std::max<long>(
        1, static_cast<long>(options.max_lookups / static_cast<double>(points.size())));
  std::vector<Candidate> nodes;
  for (std::size_t a = 0; a < offsets.size(); ++a)
    for (int y = -window; y <= window; y += top)
      for (int x = -window; x <= window; x += top) nodes.push_back({static_cast<int>(a), x, y, level, 0.0});
  bb.search(nodes.data(), nodes.data() + nodes.size());
  result.candidates_scored = bb.evaluated_;
  if (bb.exhausted_) {
    result.exhausted = true;
    result.problem =
        common::str("search stopped after ", bb.evaluated_, " candidates (max_lookups)");
    return result;
  }
  if (!bb.found_) {
    result.problem = common::str("no candidate scored above ", bb.best_score_);
    return result;
  }
  const Candidate& best = bb.best_;
  result.pose = Pose2(prediction.x() + best.x * res, prediction.y() + best.y * res,
                      prediction.theta() + offsets[best.angle]);
  result.correlative_score = bb.best_score_;
  result.success = true;
  return result;
}
}  // namespace

MatchResult ScanMatcher::correlativeSearch(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                                           const Pose2& prediction, double linear_window,
                                           double angular_window) const {
  return correlative(options_, target, points, prediction, linear_window, angular_window, options_.min_score,
                     nullptr);
}

MatchResult ScanMatcher::bestElsewhere(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                                       const Pose2& prediction, double linear_window, double angular_window,
                                       const Eigen::Vector2d& excluded, double radius,
                                       double min_score) const {
  ExcludedDisc disc;
  if (!target.empty()) {
    const double res = target.field().frame().resolution;
    disc = {(excluded.x() - prediction.x()) / res, (excluded.y() - prediction.y()) / res, radius / res};
  }
  return correlative(options_, target, points, prediction, linear_window, angular_window,
                     std::max(options_.min_score, min_score), &disc);
}


double meanScore(const grid::LikelihoodField& field, const std::vector<Eigen::Vector2d>& points,
                 const Pose2& pose) {
  const double c = std::cos(pose.theta()), s = std::sin(pose.theta());
  double sum = 0.0;
  for (const auto& p : points)
    sum += field.interpolatedScore({c * p.x() - s * p.y() + pose.x(), s * p.x() + c * p.y() + pose.y()});
  return points.empty() ? 0.0 : sum / static_cast<double>(points.size());
}

namespace {

// Laplace approximation σ² (JᵀWJ)⁻¹ from the point-to-line information `h_scan`, σ² the
// weighted residual variance, floored: a near-perfect fit does not make the map's
// artefacts confident; inflated by covariance_scale (neighbouring beams are correlated).
Eigen::Matrix3d matchCovariance(const Eigen::Matrix3d& h_scan, double weighted_r2, double weight_sum,
                                const ScanMatcherOptions& o) {
  const double sigma2 =
      std::max(weighted_r2 / std::max(1.0, weight_sum - 3.0), o.min_point_stddev * o.min_point_stddev);
  Eigen::Matrix3d info = grid::withoutNormalNoise(h_scan, o.normal_tilt_stddev) / sigma2;
  info(0, 0) += 1.0 / (o.max_translation_stddev * o.max_translation_stddev);
  info(1, 1) += 1.0 / (o.max_translation_stddev * o.max_translation_stddev);
  info(2, 2) += 1.0 / (o.max_rotation_stddev * o.max_rotation_stddev);
  Eigen::Matrix3d cov = info.inverse() * o.covariance_scale;
  cov = 0.5 * (cov + cov.transpose());
  cov(0, 0) += o.min_translation_stddev * o.min_translation_stddev;
  cov(1, 1) += o.min_translation_stddev * o.min_translation_stddev;
  cov(2, 2) += o.min_rotation_stddev * o.min_rotation_stddev;
  return cov;
}

// The covariance of a match at `pose`: σ² from the weighted likelihood-field residuals,
// the information from the scan's own geometry (point-to-line, Censi 2007): each point
// constrains only the direction of its surface normal, so a corridor's axis gets none,
// whatever small-scale artefacts the map has along its walls. Both refinements use it,
// so an edge's weight does not depend on how its pose was refined.
Eigen::Matrix3d fieldCovariance(const grid::LikelihoodField& field, const std::vector<Eigen::Vector2d>& points,
                                const Pose2& pose, const ScanMatcherOptions& o) {
  const double c2 = o.robust_distance * o.robust_distance;
  const double cap = field.options().max_distance;
  const std::vector<Eigen::Vector2d> normals = pointNormals(points, o.normal_radius);
  const double c = std::cos(pose.theta()), s = std::sin(pose.theta());
  Eigen::Matrix3d h_scan = Eigen::Matrix3d::Zero();
  double weighted_r2 = 0.0, weight_sum = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double r = pointResidual(field, pose, points[i], nullptr);
    if (r >= cap) continue;
    const double w = 1.0 / (1.0 + r * r / c2);
    weighted_r2 += w * r * r;
    weight_sum += w;
    if (normals[i].isZero()) continue;
    const Eigen::Vector2d& p = points[i];
    const Eigen::Vector2d n(c * normals[i].x() - s * normals[i].y(), s * normals[i].x() + c * normals[i].y());
    const Eigen::Vector2d dq_dtheta(-s * p.x() - c * p.y(), c * p.x() - s * p.y());
    const Eigen::RowVector3d j(n.x(), n.y(), n.dot(dq_dtheta));
    h_scan += w * j.transpose() * j;
  }
  return matchCovariance(h_scan, weighted_r2, weight_sum, o);
}

// A refinement's result before it starts: at `initial`, with a problem when there are too
// few points to refine.
MatchResult startRefinement(const std::vector<Eigen::Vector2d>& points, const Pose2& initial,
                            const ScanMatcherOptions& o) {
  MatchResult result;
  result.points = static_cast<int>(points.size());
  result.pose = initial;
  if (static_cast<int>(points.size()) < std::max(3, o.min_points))
    result.problem = common::str("too few points (", points.size(), ")");
  return result;
}

}  // namespace

MatchResult ScanMatcher::refine(const grid::LikelihoodField& field, const std::vector<Eigen::Vector2d>& points,
                                const Pose2& initial) const {
  MatchResult result = startRefinement(points, initial, options_);
  if (!result.problem.empty()) return result;
  const double wt = options_.translation_prior_weight, wr = options_.rotation_prior_weight;
  // Cauchy weights: points far from every obstacle (clutter, unseen parts of the map)
  // barely pull. Points at the distance cap have no gradient at all.
  const double c2 = options_.robust_distance * options_.robust_distance;
  const double cap = field.options().max_distance;
  // Cost: Σ ρ(d_i²) over points plus the priors towards `initial`.
  auto evaluate = [&](const Pose2& pose, Eigen::Matrix3d* h, Eigen::Vector3d* b) {
    double cost = 0.0;
    Eigen::Matrix3d hs = Eigen::Matrix3d::Zero();
    Eigen::Vector3d bs = Eigen::Vector3d::Zero();
    Eigen::RowVector3d j;
    for (const auto& p : points) {
      const double r = pointResidual(field, pose, p, h ? &j : nullptr);
      cost += c2 * std::log1p(r * r / c2);
      if (h && r < cap) {
        const double w = 1.0 / (1.0 + r * r / c2);
        hs += w * j.transpose() * j;
        bs += w * j.transpose() * r;
      }
    }
    const Eigen::Vector3d d(pose.x() - initial.x(), pose.y() - initial.y(),
                            geometry::angleDiff(pose.theta(), initial.theta()));
    cost += wt * (d.x() * d.x() + d.y() * d.y()) + wr * d.z() * d.z();
    if (h) {
      *h = hs;
      *b = bs;
      (*h)(0, 0) += wt;
      (*h)(1, 1) += wt;
      (*h)(2, 2) += wr;
      (*b) += Eigen::Vector3d(wt * d.x(), wt * d.y(), wr * d.z());
    }
    return cost;
  };

  Pose2 pose = initial;
  Eigen::Matrix3d h;
  Eigen::Vector3d b;
  double cost = evaluate(pose, &h, &b);
  for (int it = 0; it < options_.max_iterations; ++it) {
    Eigen::Matrix3d damped = h;
    damped.diagonal() += Eigen::Vector3d::Constant(1e-9);
    const Eigen::Vector3d delta = damped.ldlt().solve(-b);
    if (!delta.allFinite()) break;
    // Halve the step until the cost does not increase (the field is only piecewise smooth).
    double scale = 1.0;
    bool improved = false;
    for (int k = 0; k < 6; ++k, scale *= 0.5) {
      const Pose2 trial(pose.x() + scale * delta.x(), pose.y() + scale * delta.y(),
                        pose.theta() + scale * delta.z());
      const double trial_cost = evaluate(trial, nullptr, nullptr);
      if (trial_cost <= cost) {
        pose = trial;
        cost = trial_cost;
        improved = true;
        break;
      }
    }
    if (!improved) break;
    const double step = (scale * delta).head<2>().norm() + std::abs(scale * delta.z());
    cost = evaluate(pose, &h, &b);
    if (step < 1e-6) break;
  }
  result.pose = pose;
  // Mean interpolated likelihood-field score (comparable with the correlative score).
  result.score = meanScore(field, points, pose);
  result.covariance = fieldCovariance(field, points, pose, options_);
  result.success = pose.isFinite() && result.covariance.allFinite();
  if (!result.success) result.problem = "refinement diverged";
  return result;
}

MatchResult ScanMatcher::refineOnPoints(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                                        const Pose2& initial) const {
  MatchResult result = startRefinement(points, initial, options_);
  if (!result.problem.empty()) return result;
  grid::PointAlignmentOptions alignment;
  alignment.max_iterations = options_.max_iterations;
  alignment.max_correspondence_distance = options_.max_correspondence_distance;
  alignment.robust_distance = options_.point_robust_distance;
  alignment.translation_prior_weight = options_.translation_prior_weight;
  alignment.rotation_prior_weight = options_.rotation_prior_weight;
  const grid::PointAlignment fit = grid::alignToPoints(target.points(), points, initial, alignment);
  const Pose2& pose = fit.pose;
  result.pose = pose;
  result.score = meanScore(target.field(), points, pose);
  result.covariance = matchCovariance(fit.information, fit.weighted_r2, fit.weight_sum, options_);
  result.line_weight = fit.weight_sum;
  result.success = fit.weight_sum >= kMinLineWeight && pose.isFinite() && result.covariance.allFinite();
  if (!result.success)
    result.problem = fit.weight_sum < kMinLineWeight ? "too few points near the map's points" : "refinement diverged";
  return result;
}

MatchResult ScanMatcher::match(const MatchTarget& target, const std::vector<Eigen::Vector2d>& points,
                               const Pose2& prediction, double linear_window, double angular_window) const {
  if (linear_window < 0.0) linear_window = options_.linear_window;
  if (angular_window < 0.0) angular_window = options_.angular_window;
  MatchResult coarse = correlativeSearch(target, points, prediction, linear_window, angular_window);
  if (!coarse.success) return coarse;
  MatchResult fine = options_.point_refinement && !target.points().empty()
                         ? refineOnPoints(target, points, coarse.pose)
                         : refine(target.field(), points, coarse.pose);
  fine.correlative_score = coarse.correlative_score;
  fine.candidates_scored = coarse.candidates_scored;
  // The refinement must stay within the window and must not lose the match.
  const Eigen::Vector2d moved = fine.pose.translation() - prediction.translation();
  if (fine.success && (std::abs(moved.x()) > linear_window + target.field().frame().resolution ||
                       std::abs(moved.y()) > linear_window + target.field().frame().resolution)) {
    fine.pose = coarse.pose;
  }
  return fine;
}

}  // namespace storey::mapping
