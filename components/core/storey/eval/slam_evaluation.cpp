#include "storey/eval/slam_evaluation.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "storey/grid/occupancy_grid.h"
#include "storey/mapping/scan_matcher.h"

namespace storey::eval {

using geometry::Pose2;
using namespace mapping;  // NOLINT(google-build-using-namespace): the front end under evaluation

std::vector<Pose2> simulateOdometry(const std::vector<Pose2>& reference, const OdometryNoise& noise,
                                    std::uint64_t seed) {
  std::vector<Pose2> out;
  if (reference.empty()) return out;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  out.push_back(reference.front());
  for (std::size_t i = 1; i < reference.size(); ++i) {
    const Pose2 step = reference[i - 1].between(reference[i]);
    const double d = step.translation().norm();
    const double st = noise.translation_fraction * d;
    const double sr = noise.rotation_per_meter * d + noise.rotation_fraction * std::abs(step.theta());
    // One draw per statement: the order of evaluation of a call's arguments is unspecified
    // (gcc went right to left, clang left to right), and the same seed must give the same
    // noise with any compiler. Heading, then y, then x: gcc's order, so figures stand.
    const double noise_theta = normal(rng);
    const double noise_y = normal(rng);
    const double noise_x = normal(rng);
    const Pose2 noisy(noise.scale * step.x() + st * noise_x, noise.scale * step.y() + st * noise_y,
                      step.theta() + noise.heading_drift_per_meter * d + sr * noise_theta);
    out.push_back(out.back() * noisy);
  }
  if (noise.stall_every > 0.0 && noise.stall_length > 0.0) {
    // Travel and turning along the reference decide when a stall starts and ends.
    double travelled = 0.0, next_stall = noise.stall_every;
    double stall_travel = 0.0, stall_turn = 0.0;
    bool stalled = false;
    Pose2 held;
    for (std::size_t i = 1; i < reference.size(); ++i) {
      const Pose2 step = reference[i - 1].between(reference[i]);
      travelled += step.translation().norm();
      if (stalled) {
        stall_travel += step.translation().norm();
        stall_turn += std::abs(step.theta());
        if (stall_travel >= noise.stall_length || stall_turn >= noise.stall_length)
          stalled = false;
        else
          out[i] = held;
      } else if (travelled >= next_stall) {
        stalled = true;
        held = out[i - 1];
        out[i] = held;
        stall_travel = step.translation().norm();
        stall_turn = std::abs(step.theta());
        next_stall = travelled + noise.stall_every;
      }
    }
  }
  return out;
}

std::vector<std::size_t> thinnedIndices(const std::vector<Pose2>& poses, double min_translation,
                                        double min_rotation) {
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!kept.empty()) {
      const Pose2 step = poses[kept.back()].between(poses[i]);
      if (step.translation().norm() < min_translation && std::abs(step.theta()) < min_rotation)
        continue;
    }
    kept.push_back(i);
  }
  return kept;
}

sensor::LaserScan degradeScan(const sensor::LaserScan& scan, const LaserDegradation& d,
                              std::mt19937_64& rng) {
  sensor::LaserScan out = sensor::subsample(scan, std::max<std::size_t>(1, d.beam_step));
  if (d.field_of_view > 0.0) {
    // Beams within ±fov/2 of the sensor's axis, as one contiguous run.
    std::size_t first = out.ranges.size(), last = 0;
    for (std::size_t i = 0; i < out.ranges.size(); ++i)
      if (std::abs(out.angle(i)) <= 0.5 * d.field_of_view + 1e-9) {
        first = std::min(first, i);
        last = i;
      }
    if (first <= last) {
      out.angle_min = out.angle(first);
      out.ranges = std::vector<float>(out.ranges.begin() + static_cast<std::ptrdiff_t>(first),
                                      out.ranges.begin() + static_cast<std::ptrdiff_t>(last) + 1);
    }
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  for (std::size_t i = 0; i < out.ranges.size(); ++i) {
    const bool valid = out.isReturn(i);
    // One draw per beam whatever its range, so conditions do not shift each other's noise.
    const double noise = d.range_noise > 0.0 ? d.range_noise * normal(rng) : 0.0;
    if (!valid) continue;
    if (d.max_range > 0.0 && out.ranges[i] >= d.max_range) {
      out.ranges[i] = std::numeric_limits<float>::infinity();
      continue;
    }
    out.ranges[i] = static_cast<float>(std::max(out.range_min, out.ranges[i] + noise));
  }
  if (d.max_range > 0.0) out.range_max = std::min(out.range_max, d.max_range);
  return out;
}

OfflineRun runOffline(FloorSlam& slam, const std::vector<sensor::LaserScan>& scans,
                      const std::vector<Pose2>& odometry) {
  if (scans.size() != odometry.size()) throw std::invalid_argument("runOffline: scans and odometry differ in count");
  OfflineRun run;
  // Each scan is remembered as (node id it followed, its pose relative to that node).
  std::vector<std::pair<int, Pose2>> anchors;
  anchors.reserve(scans.size());
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const ScanResult r = slam.addScan(scans[i], odometry[i]);
    run.status.push_back(r.status);
    run.results.push_back(r);
    const auto& nodes = slam.floorGraph().nodes;
    if (nodes.empty()) {
      anchors.emplace_back(-1, r.pose);
      continue;
    }
    const auto& last = nodes.back();
    if (r.status == ScanStatus::kNode) anchors.emplace_back(r.node_id, Pose2());
    else anchors.emplace_back(last.id, last.pose.between(r.pose));
  }
  slam.finish();
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto& graph = slam.floorGraph();
  for (const auto& [id, offset] : anchors) {
    const floor::FloorNode* node = id >= 0 ? graph.findNode(id) : nullptr;
    run.trajectory.push_back(node ? node->pose * offset : offset);
  }
  return run;
}

namespace {
struct Accumulator {
  double t = 0, t2 = 0, r = 0, r2 = 0;
  std::size_t n = 0;
  void add(const Pose2& e) {
    const double et = e.translation().norm(), er = std::abs(e.theta());
    t += et;
    t2 += et * et;
    r += er;
    r2 += er * er;
    ++n;
  }
  ErrorStats stats() const {
    ErrorStats s;
    s.count = n;
    if (n == 0) return s;
    s.translation_mean = t / n;
    s.rotation_mean = r / n;
    s.translation_std = std::sqrt(std::max(0.0, t2 / n - s.translation_mean * s.translation_mean));
    s.rotation_std = std::sqrt(std::max(0.0, r2 / n - s.rotation_mean * s.rotation_mean));
    return s;
  }
};
}  // namespace

RelationErrors relationErrors(const std::vector<Pose2>& estimate, const std::vector<Pose2>& reference,
                              double far_distance, std::size_t far_pairs, std::uint64_t seed,
                              const std::vector<bool>& left_out) {
  if (estimate.size() != reference.size())
    throw std::invalid_argument("relationErrors: estimate and reference differ in count");
  if (!left_out.empty() && left_out.size() != reference.size())
    throw std::invalid_argument("relationErrors: left_out and reference differ in count");
  Accumulator nearby, far;
  auto error = [&](std::size_t i, std::size_t j) {
    return reference[i].between(reference[j]).between(estimate[i].between(estimate[j]));
  };
  auto counted = [&](std::size_t i, std::size_t j) { return left_out.empty() || !(left_out[i] || left_out[j]); };
  for (std::size_t i = 0; i + 1 < estimate.size(); ++i)
    if (counted(i, i + 1)) nearby.add(error(i, i + 1));
  if (estimate.size() >= 2) {
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, estimate.size() - 1);
    // Bounded tries: a small log may have few far pairs.
    for (std::size_t tries = 0; tries < far_pairs * 20 && far.n < far_pairs; ++tries) {
      const std::size_t i = pick(rng), j = pick(rng);
      if ((reference[i].translation() - reference[j].translation()).norm() <= far_distance) continue;
      if (!counted(i, j)) continue;
      far.add(error(i, j));
    }
  }
  return {nearby.stats(), far.stats()};
}

std::vector<ReferencePoseCheck> checkReferencePoses(const std::vector<sensor::LaserScan>& scans,
                                                   const std::vector<Pose2>& reference,
                                                   const ReferenceCheckOptions& options) {
  if (scans.size() != reference.size())
    throw std::invalid_argument("checkReferencePoses: scans and reference differ in count");
  grid::OccupancyGridOptions grid_options;
  grid_options.max_insert_range = options.max_insert_range;
  const grid::LikelihoodFieldOptions field_options;
  // A tight grid, as for the front end's local maps.
  const int pyramid_levels = 5;
  grid_options.growth_margin = MatchTarget::gridMargin(field_options, grid_options.resolution, pyramid_levels);
  const ScanMatcher matcher;
  std::vector<ReferencePoseCheck> checks(scans.size());
  const long n = static_cast<long>(scans.size()), w = options.neighbours;
  for (long k = 0; k < n; ++k) {
    ReferencePoseCheck& check = checks[static_cast<std::size_t>(k)];
    check.index = static_cast<std::size_t>(k);
    std::vector<grid::OccupancyGrid::PosedScan> neighbours;
    for (long j = std::max(0L, k - w); j <= std::min(n - 1, k + w); ++j)
      if (j != k) neighbours.push_back({&scans[static_cast<std::size_t>(j)], reference[static_cast<std::size_t>(j)]});
    if (neighbours.empty()) continue;
    grid::OccupancyGrid grid(grid_options);
    grid.insertScans(neighbours);
    const MatchTarget target(grid, field_options, pyramid_levels);
    const std::vector<Eigen::Vector2d> points =
        filterPoints(scans[static_cast<std::size_t>(k)].pointsInRobotFrame(), matcher.options().point_filter_distance);
    const Pose2& pose = reference[static_cast<std::size_t>(k)];
    check.reference_score = meanScore(target.field(), points, pose);
    const MatchResult match = matcher.match(target, points, pose, options.linear_window, options.angular_window);
    if (!match.success) continue;
    check.matched = true;
    check.match = match.pose;
    check.match_score = match.score;
    const Pose2 offset = pose.between(match.pose);
    const bool elsewhere = offset.translation().norm() >= options.min_translation ||
                           std::abs(offset.theta()) >= options.min_rotation;
    check.contradicted = elsewhere && check.reference_score < options.max_score_ratio * check.match_score;
  }
  return checks;
}

std::vector<EdgeConsistency> edgeConsistency(const floor::FloorGraph& graph,
                                             const std::map<int, Pose2>& reference) {
  std::map<floor::EdgeKind, EdgeConsistency> by_kind;
  for (const auto& edge : graph.edges) {
    const auto from = reference.find(edge.from), to = reference.find(edge.to);
    if (from == reference.end() || to == reference.end()) continue;
    const Pose2 error = from->second.between(to->second).between(edge.measurement);
    const Eigen::Vector3d e(error.x(), error.y(), error.theta());
    const Eigen::Matrix3d covariance = edge.information.inverse();
    EdgeConsistency& c = by_kind[edge.kind];
    c.kind = edge.kind;
    ++c.count;
    c.mean_nees += e.dot(edge.information * e);
    c.rms_translation_error += 0.5 * e.head<2>().squaredNorm();
    c.rms_translation_sigma += 0.5 * (covariance(0, 0) + covariance(1, 1));
    c.rms_rotation_error += e.z() * e.z();
    c.rms_rotation_sigma += covariance(2, 2);
  }
  std::vector<EdgeConsistency> out;
  for (auto& [kind, c] : by_kind) {
    const double n = static_cast<double>(c.count);
    c.mean_nees /= n;
    c.rms_translation_error = std::sqrt(c.rms_translation_error / n);
    c.rms_translation_sigma = std::sqrt(c.rms_translation_sigma / n);
    c.rms_rotation_error = std::sqrt(c.rms_rotation_error / n);
    c.rms_rotation_sigma = std::sqrt(c.rms_rotation_sigma / n);
    out.push_back(c);
  }
  return out;
}

namespace {

struct FitStep {
  double distance;                   // m, the step's length
  double turn;                       // rad, |the step's heading change|
  double translation_error_squared;  // m², both components
  double rotation_error;             // rad
};

// Minimises f over [lo, hi] (f unimodal near its minimum): a log-spaced scan, then golden-section
// search around the best sample. A rate of 0 is tried too (a model term that is not there).
template <typename F>
double minimiseRate(const F& f, double lo, double hi) {
  constexpr int kSamples = 80;
  double best = 0.0, best_value = f(0.0);
  const double ratio = std::pow(hi / lo, 1.0 / (kSamples - 1));
  double rate = lo;
  for (int i = 0; i < kSamples; ++i, rate *= ratio) {
    const double v = f(rate);
    if (v < best_value) best = rate, best_value = v;
  }
  if (best == 0.0) return 0.0;
  double a = best / ratio, b = best * ratio;
  const double golden = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - golden * (b - a), d = a + golden * (b - a);
  double fc = f(c), fd = f(d);
  for (int i = 0; i < 60; ++i) {
    if (fc < fd) {
      b = d, d = c, fd = fc;
      c = b - golden * (b - a), fc = f(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + golden * (b - a), fd = f(d);
    }
  }
  const double mid = 0.5 * (a + b);
  return f(mid) < best_value ? mid : best;
}

// −log of a zero-mean Gaussian density up to a constant: `components` independent ones with
// standard deviation sigma whose squared errors sum to `squared_error`.
double gaussianCost(double sigma, double squared_error, int components) {
  return components * std::log(sigma) + squared_error / (2.0 * sigma * sigma);
}

}  // namespace

OdometryNoiseFit fitOdometryNoise(const floor::FloorGraph& graph, const std::map<int, Pose2>& poses,
                                  const OdometryNoiseModel& floors) {
  std::vector<FitStep> steps;
  for (const auto& edge : graph.edges) {
    if (edge.kind != floor::EdgeKind::kOdometry) continue;
    const auto from = poses.find(edge.from), to = poses.find(edge.to);
    if (from == poses.end() || to == poses.end()) continue;
    const Pose2 truth = from->second.between(to->second);
    const Pose2& measured = edge.measurement;
    const Eigen::Vector2d e = measured.translation() - truth.translation();
    // Scaled by the step as `poses` have it: the measured turn holds the noise itself, and
    // on small turns that biased the heading's rate by 15 % (tests/unit/mapping).
    steps.push_back({truth.translation().norm(), std::abs(truth.theta()), e.squaredNorm(),
                     geometry::normalizeAngle(measured.theta() - truth.theta())});
  }
  OdometryNoiseFit fit;
  fit.model = floors;
  fit.steps = steps.size();
  if (steps.empty()) return fit;
  // Negative log-likelihoods up to constants: two translation components per step with standard
  // deviation max(floor, a·d); the heading with max(floor, b·d + c·|Δθ|). A zero floor would let
  // a zero rate explain an exact step with a likelihood without bound.
  const double translation_floor = std::max(floors.min_translation_stddev, 1e-9);
  const double rotation_floor = std::max(floors.min_rotation_stddev, 1e-9);
  const auto translationCost = [&](double a) {
    double cost = 0.0;
    for (const auto& s : steps) {
      cost +=
          gaussianCost(std::max(translation_floor, a * s.distance), s.translation_error_squared, 2);
    }
    return cost;
  };
  const auto rotationCost = [&](double b, double c) {
    double cost = 0.0;
    for (const auto& s : steps) {
      cost += gaussianCost(std::max(rotation_floor, b * s.distance + c * s.turn),
                           s.rotation_error * s.rotation_error, 1);
    }
    return cost;
  };
  constexpr double kLowest = 1e-4, kHighest = 2.0;  // rates per metre or per radian
  fit.model.translation_per_meter = minimiseRate(translationCost, kLowest, kHighest);
  // The two heading rates by alternating one-dimensional searches, each from the other's best.
  double b = 0.0, c = 0.0;
  for (int round = 0; round < 8; ++round) {
    const double new_b =
        minimiseRate([&](double x) { return rotationCost(x, c); }, kLowest, kHighest);
    const double new_c =
        minimiseRate([&](double x) { return rotationCost(new_b, x); }, kLowest, kHighest);
    const bool settled = std::abs(new_b - b) <= 1e-6 && std::abs(new_c - c) <= 1e-6;
    b = new_b, c = new_c;
    if (settled) break;
  }
  fit.model.rotation_per_meter = b;
  fit.model.rotation_per_radian = c;
  return fit;
}

OdometryNoiseFit fitOdometryNoise(const floor::FloorGraph& graph,
                                  const OdometryNoiseModel& floors) {
  std::map<int, Pose2> poses;
  for (const auto& node : graph.nodes) poses[node.id] = node.pose;
  return fitOdometryNoise(graph, poses, floors);
}

}  // namespace storey::eval
