// Offline runs of the front end and their evaluation against reference poses: seeded
// odometry noise on a reference trajectory, the per-scan trajectory of a run, and the
// relation-based error of Kümmerle et al. 2009 (relative poses between scan pairs).
#pragma once

#include <cstdint>
#include <map>
#include <random>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/mapping/floor_slam.h"
#include "storey/sensor/laser_scan.h"

namespace storey::eval {

// Odometry noise per step between consecutive poses: each translation component gets
// N(0, (translation_fraction·d)²), the heading N(0, (rotation_per_meter·d +
// rotation_fraction·|Δθ|)²), d the step's length. On top, systematic errors of a real robot:
// the step's translation scaled by `scale` (a wheel radius 3 % too large: 1.03) and the
// heading turned by heading_drift_per_meter·d (unequal wheels); and stalls: every
// stall_every metres of travel the odometry holds its pose for stall_length metres (or
// stall_length radians of turning, whichever comes first), then catches up in one step.
struct OdometryNoise {
  double translation_fraction = 0.05;
  double rotation_per_meter = 2.0 * M_PI / 180.0;
  double rotation_fraction = 0.02;
  double scale = 1.0;
  double heading_drift_per_meter = 0.0;  // rad per m
  double stall_every = 0.0;              // m (0: no stalls)
  double stall_length = 0.0;             // m, or rad turned
};

// Odometry poses chained from the reference's steps with seeded noise (first pose kept).
// The systematic errors and stalls draw nothing: with them off the same seed gives the
// same noise.
std::vector<geometry::Pose2> simulateOdometry(const std::vector<geometry::Pose2>& reference,
                                              const OdometryNoise& noise, std::uint64_t seed);

// Indices of the poses kept when a log is thinned as a sparser recording would be: the
// first, then each pose at least min_translation (m) or min_rotation (rad) from the last kept.
std::vector<std::size_t> thinnedIndices(const std::vector<geometry::Pose2>& poses,
                                        double min_translation, double min_rotation);

// A laser other than the logged one, made from its scans: returns beyond max_range become no
// returns (a shorter-range sensor), every beam_step-th beam kept, Gaussian range noise
// added, and beams outside ±field_of_view/2 of the sensor's forward axis dropped.
struct LaserDegradation {
  double max_range = 0.0;  // m (0: as logged)
  std::size_t beam_step = 1;
  double range_noise = 0.0;    // m, standard deviation
  double field_of_view = 0.0;  // rad (0: as logged)
};
// One scan degraded; the noise draws from `rng`.
sensor::LaserScan degradeScan(const sensor::LaserScan& scan, const LaserDegradation& degradation,
                              std::mt19937_64& rng);

struct OfflineRun {
  std::vector<geometry::Pose2> trajectory;  // per scan, at the final graph's poses
  std::vector<mapping::ScanStatus> status;           // per scan
  std::vector<mapping::ScanResult> results;          // per scan, as addScan returned it
  double seconds = 0.0;                     // processing time (wall clock)
};

// Feeds every scan with its odometry to `slam`, finishes it (FloorSlam::finish), and returns each
// scan's pose: a node's pose, or the pose of the node it followed composed with the
// odometry motion since (re-expressed after the final optimisation).
OfflineRun runOffline(mapping::FloorSlam& slam, const std::vector<sensor::LaserScan>& scans,
                      const std::vector<geometry::Pose2>& odometry);

struct ErrorStats {
  std::size_t count = 0;
  double translation_mean = 0.0, translation_std = 0.0;  // m
  double rotation_mean = 0.0, rotation_std = 0.0;        // rad
};
struct RelationErrors {
  ErrorStats nearby;  // consecutive scans
  ErrorStats far;     // random pairs more than far_distance apart in the reference
};
// Relative pose error |(x_i⁻¹ x_j) ⊖ (r_i⁻¹ r_j)| per pair, translation and rotation.
// Pairs with a pose marked in `left_out` (same size as the reference, or empty for none)
// are not counted; far pairs are drawn until far_pairs others are found.
RelationErrors relationErrors(const std::vector<geometry::Pose2>& estimate,
                              const std::vector<geometry::Pose2>& reference,
                              double far_distance = 10.0, std::size_t far_pairs = 5000,
                              std::uint64_t seed = 1, const std::vector<bool>& left_out = {});

// Reference poses that their own scans contradict. The corrected logs are SLAM results
// with errors of their own, and Kümmerle et al. 2009 had a person accept each reference
// relation before using it; this is an automatic stand-in. Scan k is matched (ScanMatcher,
// likelihood field) against its neighbours' scans k−W … k+W, without k, rendered at their
// reference poses, in a window around its own reference pose. The reference pose is
// contradicted when the match lies clearly elsewhere (at least min_translation or
// min_rotation away) and the scan fits there clearly better: its mean score at the
// reference pose is below max_score_ratio × the match's. It uses the log alone, never an
// estimate, so it judges every estimate of the log the same way.
struct ReferenceCheckOptions {
  int neighbours = 5;             // W, scans on each side
  double linear_window = 0.5;     // m, search half width around the reference pose
  double angular_window = 0.5;    // rad
  double min_translation = 0.1;   // m
  double min_rotation = 2.0 * M_PI / 180.0;  // rad
  double max_score_ratio = 0.7;
  double max_insert_range = 20.0;  // m, farther returns are left out of the neighbours' map
};
struct ReferencePoseCheck {
  std::size_t index = 0;
  bool matched = false;            // the scan matched its neighbours somewhere in the window
  geometry::Pose2 match;           // where
  double reference_score = 0.0;    // mean per-point score at the reference pose
  double match_score = 0.0;        // and at the match
  bool contradicted = false;
};
// One check per scan, in order.
std::vector<ReferencePoseCheck> checkReferencePoses(const std::vector<sensor::LaserScan>& scans,
                                                   const std::vector<geometry::Pose2>& reference,
                                                   const ReferenceCheckOptions& options = {});

// Whether the graph's edges claim the accuracy they have: each edge's error against the
// reference relative pose, normalised by its information (NEES; 3 on average for an edge
// whose covariance is right, much less for an inflated one). Per edge kind; edges with a
// node missing from `reference` (node id → pose) are left out.
struct EdgeConsistency {
  floor::EdgeKind kind = floor::EdgeKind::kOdometry;
  std::size_t count = 0;
  double mean_nees = 0.0;
  double rms_translation_error = 0.0, rms_translation_sigma = 0.0;  // m, per axis
  double rms_rotation_error = 0.0, rms_rotation_sigma = 0.0;        // rad
};
std::vector<EdgeConsistency> edgeConsistency(const floor::FloorGraph& graph,
                                             const std::map<int, geometry::Pose2>& reference);

// The odometry noise model (floor_slam.h) that makes the graph's odometry edges most likely
// (maximum likelihood) when `poses` (node id → pose) are the true ones: the finished graph's
// own poses, which needs nothing but the run, or a reference. Each odometry edge is one step;
// its error is the measured step minus the step between the two poses, per component in the
// older node's frame, scaled by the step between the poses, as simulateOdometry draws it. The rates
// (translation_per_meter, rotation_per_meter, rotation_per_radian) are fitted; the minimum standard
// deviations are taken from `floors` and kept. Fitted to the graph's own poses, the rates are
// biased both ways: low where the scans said little and the graph kept the odometry (a bare
// corridor's axis), high by the graph's own errors (docs/floor_mapper.md, "Odometry noise fitted
// to the graph"). Without odometry edges, `steps` is 0 and the model is `floors`.
struct OdometryNoiseFit {
  mapping::OdometryNoiseModel model;
  std::size_t steps = 0;  // odometry edges with both nodes in `poses`
};
OdometryNoiseFit fitOdometryNoise(const floor::FloorGraph& graph,
                                  const std::map<int, geometry::Pose2>& poses,
                                  const mapping::OdometryNoiseModel& floors = {});
// The same with the graph's own node poses, which needs nothing but the run.
OdometryNoiseFit fitOdometryNoise(const floor::FloorGraph& graph,
                                  const mapping::OdometryNoiseModel& floors = {});

}  // namespace storey::eval
