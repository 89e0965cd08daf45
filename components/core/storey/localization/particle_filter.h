// Global Monte Carlo localisation of one robot's scans in another floor's map (Thrun,
// Burgard, Fox, Probabilistic Robotics: odometry motion model, ch. 5.4; likelihood-field
// sensor model, ch. 6.4; low-variance resampling, ch. 4.3) with KLD-sampling (Fox 2003)
// so a whole floor starts with tens of thousands of particles and a converged filter
// keeps a few hundred.
//
// Particles are stored as separate arrays (x, y, theta, weight) and the sensor update is a
// tight loop over particles x beams doing one table lookup in the likelihood field's
// per-cell log p each, so the compiler can keep it in registers and the two cores can
// share the work.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "storey/common/config.h"
#include "storey/geometry/pose2.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/sensor/laser_scan.h"

namespace storey::localization {

// Noise of the odometry motion model (Probabilistic Robotics table 5.6), as standard
// deviations: sigma_rot = rot_rot * |rot| + rot_trans * trans (+ min_rotation), and
// sigma_trans = trans_trans * trans + trans_rot * (|rot1| + |rot2|) (+ min_translation).
struct MotionNoiseOptions {
  double rot_rot = 0.1;           // rad per rad
  double rot_trans = 0.05;        // rad per metre
  double trans_trans = 0.1;       // metre per metre
  double trans_rot = 0.02;        // metre per rad
  double min_translation = 0.02;  // metres, added every step to keep particles diverse
  double min_rotation = 0.01;     // rad
};

struct ParticleFilterOptions {
  // Initial particles: density over the map's free space, clamped to [min, max].
  double initial_particles_per_m2 = 100.0;
  int max_particles = 50000;
  int min_particles = 300;
  // KLD-sampling: bound on the Kullback-Leibler error (epsilon) with probability 1-delta
  // (z is the upper 1-delta quantile of N(0,1)); histogram bins in x, y and heading.
  double kld_epsilon = 0.05;
  double kld_z = 2.326;  // delta = 0.01
  double kld_bin_xy = 0.25;
  double kld_bin_theta = 0.17453292519943295;  // 10 degrees
  // Resample when the effective sample size falls below this fraction of the particles.
  double resample_threshold = 0.5;
  // Beams used per scan (evenly subsampled valid returns).
  int beams = 60;
  // Coarse-to-fine: while the filter holds more than `coarse_particles` particles (the
  // global phase, spread over the whole floor) only `coarse_beams` beams are used. A scan
  // counts as `effective_beams` independent beams whatever their number, so the weights
  // keep their scale; once the filter has shrunk, all `beams` are used. 0 turns it off.
  int coarse_beams = 0;
  int coarse_particles = 5000;
  // Observation weight: log w += effective_beams * (mean over beams of log p(beam)). The
  // beams of one scan are far from independent (the map and the scan share errors), so a
  // scan counts as this many independent beams; more makes the filter collapse early onto
  // wrong modes.
  double effective_beams = 3.0;
  // log-weight added to particles standing outside the map's free space (in walls or in
  // unknown space): a robot stands on free floor.
  double off_free_log_penalty = -3.0;
  MotionNoiseOptions motion;
  // Convergence: `convergence_mass` of the probability mass within `convergence_radius`
  // (metres) of the weighted mean position and within `convergence_angle` (rad) of the
  // mean heading.
  double convergence_mass = 0.99;
  double convergence_radius = 0.5;
  double convergence_angle = 0.35;
};
// Reads the keys a unit's file may set (initial_particles_per_m2, max_particles,
// min_particles, beams, coarse_beams, coarse_particles, effective_beams, convergence_mass,
// convergence_radius, convergence_angle) over `base`; the KLD, resampling, off-free and
// motion-noise values are the filter's own.
ParticleFilterOptions readParticleFilterOptions(const common::ConfigNode& node,
                                                ParticleFilterOptions base);

// What the filter holds right now.
struct FilterState {
  geometry::Pose2 mean;      // weighted mean pose (circular mean heading)
  double mass_within = 0.0;  // weight within the convergence radius and angle of `mean`
  bool converged = false;
  std::size_t particles = 0;
};

// The map the filter localises in: the occupancy grid's free cells (for uniform
// initialisation and the free-space check) and the likelihood field.
class LocalizationMap {
 public:
  LocalizationMap(const grid::OccupancyGrid& grid,
                  const grid::LikelihoodFieldOptions& field_options);

  const grid::LikelihoodField& field() const { return field_; }
  const grid::GridFrame& frame() const { return field_.frame(); }
  const std::vector<std::uint32_t>& freeCells() const { return free_cells_; }
  bool isFree(double x, double y) const {
    const grid::GridFrame& f = field_.frame();
    const double u = (x - f.origin_x) / f.resolution, v = (y - f.origin_y) / f.resolution;
    if (!(u >= 0.0 && v >= 0.0 && u < f.width && v < f.height)) return false;
    return free_mask_[static_cast<std::size_t>(v) * static_cast<std::size_t>(f.width) +
                      static_cast<std::size_t>(u)] != 0;
  }
  // log p per cell with a one-cell border holding the outside value, so the sensor update
  // clamps coordinates instead of branching: cell (cx, cy) is at (cx + 1, cy + 1).
  const std::vector<float>& paddedLogLikelihood() const { return padded_; }
  int paddedStride() const { return field_.frame().width + 2; }
  double freeArea() const;  // m^2
  std::size_t occupiedCells() const { return occupied_cells_; }

 private:
  grid::LikelihoodField field_;
  std::vector<std::uint8_t> free_mask_;  // per cell of the field's frame
  std::vector<std::uint32_t> free_cells_;
  std::vector<float> padded_;
  std::size_t occupied_cells_ = 0;
};

// Negative information for the sensor model (optional): the likelihood field scores where a
// beam ends and not what it passed, so a pose whose beams cross walls can outscore the
// true one (a corridor seen from inside fits both ways round when its open end shows
// rooms the reference does not have). `distance` holds, per cell of `frame`, metres to
// the nearest wall cell (0 on one), capped, for sphere tracing a beam.
struct WallModel {
  grid::GridFrame frame;
  std::vector<float> distance;
  // Does the segment from `from` to `to` pass a wall cell?
  bool crosses(const Eigen::Vector2d& from, const Eigen::Vector2d& to) const;
};
// `walls`: 1 per wall cell of `frame`. Distances are capped at `cap` metres.
WallModel makeWallModel(const grid::GridFrame& frame, const std::vector<std::uint8_t>& walls,
                        double cap = 2.0);

class ParticleFilter {
 public:
  ParticleFilter(const LocalizationMap& map, const ParticleFilterOptions& options,
                 std::uint64_t seed);

  // Particles uniform over the free space (global localisation).
  void initializeUniform();
  // Particles drawn around a known pose (tracking, e.g. to learn l_min).
  void initializeAround(const geometry::Pose2& pose, double sigma_xy, double sigma_theta,
                        int count);

  // Moves every particle by the odometry increment `delta` (robot frame) with sampled noise.
  void predict(const geometry::Pose2& delta);
  // Weights the particles by `scan`; returns l_t, the mean over particles of the
  // observation likelihood, where one particle's likelihood is the geometric mean of
  // its beams' p (so l_t does not depend on how many beams were used).
  double update(const sensor::LaserScan& scan);
  // With a wall model, update() also traces `beams` of each scan per particle (up to
  // `margin` metres short of the endpoint) and adds effective_beams * (fraction crossing
  // a wall) * log_p_through to its log-weight. nullptr turns it off (the default).
  void setWallModel(const WallModel* model, int beams, double log_p_through, double margin);
  // Low-variance resampling when the effective sample size is low, then KLD-sampling
  // resizes the set. Returns true when it resampled.
  bool resampleIfNeeded();
  FilterState state() const;

  std::size_t size() const { return x_.size(); }
  const std::vector<double>& xs() const { return x_; }
  const std::vector<double>& ys() const { return y_; }
  const std::vector<double>& thetas() const { return theta_; }
  const std::vector<double>& weights() const { return w_; }
  // Particle-beam likelihood evaluations since construction (for benchmarks).
  std::uint64_t beamEvaluations() const { return beam_evaluations_; }

 private:
  void resize(std::size_t n);
  void systematicResample(std::size_t n);
  std::size_t kldBound(std::size_t bins) const;
  std::size_t occupiedBins() const;

  const LocalizationMap& map_;
  ParticleFilterOptions options_;
  std::mt19937_64 rng_;
  std::vector<double> x_, y_, theta_, w_;
  std::vector<double> log_w_;  // scratch
  std::uint64_t beam_evaluations_ = 0;
  const WallModel* walls_ = nullptr;
  int wall_beams_ = 0;
  double wall_log_p_ = 0.0;
  double wall_margin_ = 0.0;
};

// Endpoints of up to `beams` evenly spread valid returns, in the robot frame.
std::vector<Eigen::Vector2d> selectBeams(const sensor::LaserScan& scan, int beams);

}  // namespace storey::localization
