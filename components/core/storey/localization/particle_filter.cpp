#include "storey/localization/particle_filter.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace storey::localization {

using geometry::normalizeAngle;
using geometry::Pose2;

ParticleFilterOptions readParticleFilterOptions(const common::ConfigNode& node,
                                                ParticleFilterOptions o) {
  o.initial_particles_per_m2 =
      node.getDouble("initial_particles_per_m2", o.initial_particles_per_m2, 0.01, 10000.0);
  o.max_particles = node.getInt("max_particles", o.max_particles, 10, 10000000);
  o.min_particles = node.getInt("min_particles", o.min_particles, 10, 10000000);
  if (o.min_particles > o.max_particles)
    node.fail("min_particles", "must not exceed max_particles");
  o.beams = node.getInt("beams", o.beams, 1, 100000);
  o.coarse_beams = node.getInt("coarse_beams", o.coarse_beams, 0, 100000);
  o.coarse_particles = node.getInt("coarse_particles", o.coarse_particles, 1, 100000000);
  o.effective_beams = node.getDouble("effective_beams", o.effective_beams, 1e-3, 100000.0);
  o.convergence_mass = node.getDouble("convergence_mass", o.convergence_mass, 0.5, 1.0);
  o.convergence_radius = node.getDouble("convergence_radius", o.convergence_radius, 0.01, 100.0);
  o.convergence_angle = node.getDouble("convergence_angle", o.convergence_angle, 0.001, M_PI);
  node.finish();
  return o;
}

LocalizationMap::LocalizationMap(const grid::OccupancyGrid& grid,
                                 const grid::LikelihoodFieldOptions& field_options)
    : field_(grid, field_options) {
  const grid::GridFrame& f = field_.frame();
  free_mask_.assign(f.cellCount(), 0);
  for (int cy = 0; cy < f.height; ++cy) {
    for (int cx = 0; cx < f.width; ++cx) {
      const grid::CellState s = grid.stateAt(cx, cy);
      const std::size_t i = f.index(cx, cy);
      if (s == grid::CellState::kFree) {
        free_mask_[i] = 1;
        free_cells_.push_back(static_cast<std::uint32_t>(i));
      } else if (s == grid::CellState::kOccupied) {
        ++occupied_cells_;
      }
    }
  }
  const int stride = f.width + 2;
  padded_.assign(static_cast<std::size_t>(stride) * static_cast<std::size_t>(f.height + 2),
                 field_.outsideLogLikelihood());
  const auto& table = field_.logLikelihood().data;
  for (int cy = 0; cy < f.height; ++cy)
    std::copy(table.begin() + static_cast<std::ptrdiff_t>(f.index(0, cy)),
              table.begin() + static_cast<std::ptrdiff_t>(f.index(0, cy)) + f.width,
              padded_.begin() + static_cast<std::ptrdiff_t>(cy + 1) * stride + 1);
}

double LocalizationMap::freeArea() const {
  const double r = frame().resolution;
  return static_cast<double>(free_cells_.size()) * r * r;
}

std::vector<Eigen::Vector2d> selectBeams(const sensor::LaserScan& scan, int beams) {
  std::vector<Eigen::Vector2d> all = scan.pointsInRobotFrame();
  if (beams <= 0 || all.size() <= static_cast<std::size_t>(beams)) return all;
  std::vector<Eigen::Vector2d> out;
  out.reserve(beams);
  const double step = static_cast<double>(all.size()) / beams;
  for (int i = 0; i < beams; ++i) out.push_back(all[static_cast<std::size_t>(i * step)]);
  return out;
}

WallModel makeWallModel(const grid::GridFrame& frame, const std::vector<std::uint8_t>& walls,
                        double cap) {
  WallModel m;
  m.frame = frame;
  const int w = frame.width, h = frame.height;
  const float big = static_cast<float>(cap);
  m.distance.assign(frame.cellCount(), big);
  for (std::size_t i = 0; i < walls.size() && i < m.distance.size(); ++i)
    if (walls[i]) m.distance[i] = 0.0f;
  // Two-pass chamfer distance (3-4 weights, within 8 % of Euclidean, never above it by more
  // than that; crosses() steps conservatively).
  const float r = static_cast<float>(frame.resolution), rd = r * 1.41421356f;
  auto relax = [&](int x, int y, int dx, int dy, float cost) {
    const int nx = x + dx, ny = y + dy;
    if (nx < 0 || ny < 0 || nx >= w || ny >= h) return;
    float& d = m.distance[frame.index(x, y)];
    d = std::min(d, m.distance[frame.index(nx, ny)] + cost);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      relax(x, y, -1, 0, r);
      relax(x, y, 0, -1, r);
      relax(x, y, -1, -1, rd);
      relax(x, y, 1, -1, rd);
    }
  for (int y = h - 1; y >= 0; --y)
    for (int x = w - 1; x >= 0; --x) {
      relax(x, y, 1, 0, r);
      relax(x, y, 0, 1, r);
      relax(x, y, 1, 1, rd);
      relax(x, y, -1, 1, rd);
    }
  return m;
}

bool WallModel::crosses(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const {
  const Eigen::Vector2d d = to - from;
  const double length = d.norm();
  if (length <= 0.0 || frame.width <= 0 || frame.height <= 0) return false;
  const Eigen::Vector2d u = d / length;
  // Clip the segment to the map's box (no walls outside it; Liang-Barsky).
  double t0 = 0.0, t1 = length;
  const double lo[2] = {frame.origin_x, frame.origin_y}, hi[2] = {frame.maxX(), frame.maxY()};
  for (int a = 0; a < 2; ++a) {
    if (std::abs(u[a]) < 1e-12) {
      if (from[a] < lo[a] || from[a] >= hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - from[a]) / u[a], tb = (hi[a] - from[a]) / u[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  const double res = frame.resolution, min_step = 0.5 * res;
  for (double t = t0; t < t1;) {
    const Eigen::Vector2d p = from + t * u;
    const int cx = grid::floorToInt((p.x() - frame.origin_x) / res);
    const int cy = grid::floorToInt((p.y() - frame.origin_y) / res);
    if (!frame.contains(cx, cy)) {  // on the box's far edge by rounding
      t += min_step;
      continue;
    }
    const double dist = distance[frame.index(cx, cy)];
    if (dist <= 0.0) return true;
    // The point may be up to 0.71 cells from its cell's centre, and so may the wall's
    // nearest point from its own; the chamfer distance is within 8 % of the true one:
    // step no further than 0.92 of it less 1.5 cells.
    t += std::max(0.92 * dist - 1.5 * res, min_step);
  }
  return false;
}

void ParticleFilter::setWallModel(const WallModel* model, int beams, double log_p_through,
                                  double margin) {
  walls_ = model;
  wall_beams_ = std::max(1, beams);
  wall_log_p_ = log_p_through;
  wall_margin_ = margin;
}

ParticleFilter::ParticleFilter(const LocalizationMap& map, const ParticleFilterOptions& options,
                               std::uint64_t seed)
    : map_(map), options_(options), rng_(seed) {}

void ParticleFilter::resize(std::size_t n) {
  x_.resize(n);
  y_.resize(n);
  theta_.resize(n);
  w_.assign(n, n ? 1.0 / static_cast<double>(n) : 0.0);
}

void ParticleFilter::initializeUniform() {
  const auto& cells = map_.freeCells();
  if (cells.empty()) {
    resize(0);
    return;
  }
  const double wanted = map_.freeArea() * options_.initial_particles_per_m2;
  const std::size_t n =
      static_cast<std::size_t>(std::clamp(wanted, static_cast<double>(options_.min_particles),
                                          static_cast<double>(options_.max_particles)));
  resize(n);
  const grid::GridFrame& f = map_.frame();
  std::uniform_int_distribution<std::size_t> pick(0, cells.size() - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t j = 0; j < n; ++j) {
    const std::uint32_t c = cells[pick(rng_)];
    const int cx = static_cast<int>(c % static_cast<std::uint32_t>(f.width));
    const int cy = static_cast<int>(c / static_cast<std::uint32_t>(f.width));
    x_[j] = f.origin_x + (cx + unit(rng_)) * f.resolution;
    y_[j] = f.origin_y + (cy + unit(rng_)) * f.resolution;
    theta_[j] = -M_PI + 2.0 * M_PI * unit(rng_);
  }
}

void ParticleFilter::initializeAround(const Pose2& pose, double sigma_xy, double sigma_theta,
                                      int count) {
  resize(static_cast<std::size_t>(std::max(1, count)));
  std::normal_distribution<double> n01(0.0, 1.0);
  for (std::size_t j = 0; j < x_.size(); ++j) {
    x_[j] = pose.x() + sigma_xy * n01(rng_);
    y_[j] = pose.y() + sigma_xy * n01(rng_);
    theta_[j] = normalizeAngle(pose.theta() + sigma_theta * n01(rng_));
  }
}

void ParticleFilter::predict(const Pose2& delta) {
  double trans = std::hypot(delta.x(), delta.y());
  double rot1 = trans < 1e-6 ? 0.0 : std::atan2(delta.y(), delta.x());
  if (std::abs(rot1) > M_PI / 2) {  // driving backwards
    rot1 = normalizeAngle(rot1 - M_PI);
    trans = -trans;
  }
  const double rot2 = normalizeAngle(delta.theta() - rot1);
  const MotionNoiseOptions& m = options_.motion;
  const double at = std::abs(trans);
  const double s_rot1 = m.rot_rot * std::abs(rot1) + m.rot_trans * at + m.min_rotation;
  const double s_trans =
      m.trans_trans * at + m.trans_rot * (std::abs(rot1) + std::abs(rot2)) + m.min_translation;
  const double s_rot2 = m.rot_rot * std::abs(rot2) + m.rot_trans * at + m.min_rotation;
  std::normal_distribution<double> n01(0.0, 1.0);
  for (std::size_t j = 0; j < x_.size(); ++j) {
    const double r1 = rot1 + s_rot1 * n01(rng_);
    const double t = trans + s_trans * n01(rng_);
    const double r2 = rot2 + s_rot2 * n01(rng_);
    const double heading = theta_[j] + r1;
    x_[j] += t * std::cos(heading);
    y_[j] += t * std::sin(heading);
    theta_[j] = normalizeAngle(heading + r2);
  }
}

double ParticleFilter::update(const sensor::LaserScan& scan) {
  const bool coarse =
      options_.coarse_beams > 0 && x_.size() > static_cast<std::size_t>(options_.coarse_particles);
  const std::vector<Eigen::Vector2d> beams =
      selectBeams(scan, coarse ? options_.coarse_beams : options_.beams);
  const std::size_t nb = beams.size(), n = x_.size();
  if (nb == 0 || n == 0) return 0.0;
  std::vector<float> bx(nb), by(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    bx[b] = static_cast<float>(beams[b].x());
    by[b] = static_cast<float>(beams[b].y());
  }
  const grid::GridFrame& f = map_.frame();
  const float* table = map_.paddedLogLikelihood().data();
  const int istride = map_.paddedStride();
  const double inv_res = 1.0 / f.resolution;
  // Padded cell coordinates: the map's cell c is at c + 1; anything beyond lands on the
  // border (the outside value) by clamping.
  const double ox = f.origin_x - f.resolution, oy = f.origin_y - f.resolution;
  const float max_u = static_cast<float>(f.width + 1), max_v = static_cast<float>(f.height + 1);
  const double inv_nb = 1.0 / static_cast<double>(nb);
  log_w_.resize(n);
  double sum_likelihood = 0.0, max_log = -std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < n; ++j) {
    // Single precision is plenty here (the beam loop is in float) and sincosf costs about
    // half of sincos.
    const float th = static_cast<float>(theta_[j]);
    const float c = std::cos(th), s = std::sin(th);
    const float px = static_cast<float>((x_[j] - ox) * inv_res);
    const float py = static_cast<float>((y_[j] - oy) * inv_res);
    const float cr = c * static_cast<float>(inv_res), sr = s * static_cast<float>(inv_res);
    float sum = 0.0f;
    for (std::size_t b = 0; b < nb; ++b) {
      const float u = std::min(std::max(px + cr * bx[b] - sr * by[b], 0.0f), max_u);
      const float v = std::min(std::max(py + sr * bx[b] + cr * by[b], 0.0f), max_v);
      // float -> int (not -> size_t, which costs a branchy conversion on x86-64)
      sum += table[static_cast<int>(v) * istride + static_cast<int>(u)];
    }
    const double mean_log = static_cast<double>(sum) * inv_nb;
    sum_likelihood += std::exp(mean_log);
    double lw = std::log(std::max(w_[j], 1e-300)) + options_.effective_beams * mean_log;
    if (!map_.isFree(x_[j], y_[j])) lw += options_.off_free_log_penalty;
    log_w_[j] = lw;
    max_log = std::max(max_log, lw);
  }
  beam_evaluations_ += static_cast<std::uint64_t>(n) * nb;
  if (walls_) {
    // Negative information: beams that would have passed a wall to reach their endpoint.
    const std::vector<Eigen::Vector2d> traced = selectBeams(scan, wall_beams_);
    const Eigen::Vector2d sensor = scan.sensor_offset.translation();
    std::vector<Eigen::Vector2d> stop(traced.size());
    for (std::size_t b = 0; b < traced.size(); ++b) {
      const Eigen::Vector2d d = traced[b] - sensor;
      const double length = d.norm();
      stop[b] = length > wall_margin_
                    ? Eigen::Vector2d(sensor + d * ((length - wall_margin_) / length))
                    : sensor;
    }
    const double scale = options_.effective_beams * wall_log_p_ /
                         static_cast<double>(std::max<std::size_t>(1, traced.size()));
    max_log = -std::numeric_limits<double>::infinity();
    std::vector<Eigen::Vector2d> stop_ends;  // one particle's, reused
    for (std::size_t j = 0; j < n; ++j) {
      const Pose2 pose(x_[j], y_[j], theta_[j]);
      const Eigen::Vector2d origin = pose.transformPoint(sensor);
      int crossed = 0;
      pose.transformPoints(stop, &stop_ends);
      for (const auto& end : stop_ends) crossed += walls_->crosses(origin, end);
      log_w_[j] += scale * crossed;
      max_log = std::max(max_log, log_w_[j]);
    }
  }
  double total = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    w_[j] = std::exp(log_w_[j] - max_log);
    total += w_[j];
  }
  for (double& w : w_) w /= total;
  return sum_likelihood / static_cast<double>(n);
}

void ParticleFilter::systematicResample(std::size_t n) {
  const std::size_t old = x_.size();
  std::vector<double> nx(n), ny(n), nt(n);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double step = 1.0 / static_cast<double>(n);
  double u = unit(rng_) * step, cumulative = w_[0];
  std::size_t i = 0;
  for (std::size_t m = 0; m < n; ++m) {
    while (u > cumulative && i + 1 < old) cumulative += w_[++i];
    nx[m] = x_[i];
    ny[m] = y_[i];
    nt[m] = theta_[i];
    u += step;
  }
  x_.swap(nx);
  y_.swap(ny);
  theta_.swap(nt);
  w_.assign(n, step);
}

std::size_t ParticleFilter::occupiedBins() const {
  std::vector<std::uint64_t> keys(x_.size());
  const double bxy = options_.kld_bin_xy, bt = options_.kld_bin_theta;
  for (std::size_t j = 0; j < x_.size(); ++j) {
    const auto ix =
        static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(x_[j] / bxy)) + (1 << 20));
    const auto iy =
        static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(y_[j] / bxy)) + (1 << 20));
    const auto it = static_cast<std::uint64_t>(std::floor((theta_[j] + M_PI) / bt));
    keys[j] = (ix & 0x1fffff) | ((iy & 0x1fffff) << 21) | ((it & 0x3ff) << 42);
  }
  std::sort(keys.begin(), keys.end());
  return static_cast<std::size_t>(std::unique(keys.begin(), keys.end()) - keys.begin());
}

std::size_t ParticleFilter::kldBound(std::size_t bins) const {
  if (bins < 2) return static_cast<std::size_t>(options_.min_particles);
  const double k1 = static_cast<double>(bins - 1);
  const double a = 2.0 / (9.0 * k1);
  const double c = 1.0 - a + std::sqrt(a) * options_.kld_z;
  return static_cast<std::size_t>(std::ceil(k1 / (2.0 * options_.kld_epsilon) * c * c * c));
}

bool ParticleFilter::resampleIfNeeded() {
  if (x_.empty()) return false;
  double sum_sq = 0.0;
  for (double w : w_) sum_sq += w * w;
  const double n = static_cast<double>(x_.size());
  if (1.0 / sum_sq >= options_.resample_threshold * n) return false;
  systematicResample(x_.size());
  const std::size_t target =
      std::clamp(kldBound(occupiedBins()), static_cast<std::size_t>(options_.min_particles),
                 static_cast<std::size_t>(options_.max_particles));
  if (target != x_.size()) systematicResample(target);
  return true;
}

FilterState ParticleFilter::state() const {
  FilterState s;
  s.particles = x_.size();
  if (x_.empty()) return s;
  double mx = 0.0, my = 0.0, mc = 0.0, ms = 0.0;
  for (std::size_t j = 0; j < x_.size(); ++j) {
    mx += w_[j] * x_[j];
    my += w_[j] * y_[j];
    mc += w_[j] * std::cos(theta_[j]);
    ms += w_[j] * std::sin(theta_[j]);
  }
  s.mean = Pose2(mx, my, std::atan2(ms, mc));
  const double r2 = options_.convergence_radius * options_.convergence_radius;
  double within = 0.0;
  for (std::size_t j = 0; j < x_.size(); ++j) {
    const double dx = x_[j] - mx, dy = y_[j] - my;
    if (dx * dx + dy * dy <= r2 &&
        std::abs(normalizeAngle(theta_[j] - s.mean.theta())) <= options_.convergence_angle)
      within += w_[j];
  }
  s.mass_within = within;
  s.converged = within >= options_.convergence_mass;
  return s;
}

}  // namespace storey::localization
