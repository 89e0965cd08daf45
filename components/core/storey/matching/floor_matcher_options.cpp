// Reading FloorMatcherOptions from YAML, and the names of candidate verdicts.
#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "storey/common/log.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/floor_matcher_internal.h"
#include "storey/matching/retraction.h"

namespace storey::matching {

using namespace detail;  // NOLINT(google-build-using-namespace): the stages' shared helpers

localization::ParticleFilterOptions shippedMatcherFilter() {
  namespace f = shipped_matcher::filter;
  localization::ParticleFilterOptions o;
  o.initial_particles_per_m2 = f::initial_particles_per_m2;
  o.max_particles = f::max_particles;
  o.min_particles = f::min_particles;
  o.beams = f::beams;
  o.coarse_beams = f::coarse_beams;
  o.coarse_particles = f::coarse_particles;
  o.effective_beams = f::effective_beams;
  o.convergence_mass = f::convergence_mass;
  o.convergence_radius = f::convergence_radius;
  o.convergence_angle = f::convergence_angle;
  return o;
}

FloorMatcherOptions readFloorMatcherOptions(const common::ConfigNode& node) {
  FloorMatcherOptions o;
  if (node.has("filter")) o.filter = readParticleFilterOptions(node.child("filter"), o.filter);
  o.min_sequence = node.getInt("min_sequence", o.min_sequence, 1, 100000);
  o.max_sequence = node.getInt("max_sequence", o.max_sequence, 1, 100000);
  if (o.max_sequence < o.min_sequence) node.fail("max_sequence", "must be at least min_sequence");
  o.restart_stride = node.getInt("restart_stride", o.restart_stride, 1, 100000);
  o.likelihood_quantile = node.getDouble("likelihood_quantile", o.likelihood_quantile, 0.0, 1.0);
  o.likelihood_scale = node.getDouble("likelihood_scale", o.likelihood_scale, 0.0, 10.0);
  o.learning_particles = node.getInt("learning_particles", o.learning_particles, 10, 1000000);
  o.refine_iterations = node.getInt("refine_iterations", o.refine_iterations, 0, 1000);
  o.refine_beams = node.getInt("refine_beams", o.refine_beams, 1, 100000);
  o.max_refine_correction =
      node.getDouble("max_refine_correction", o.max_refine_correction, 0.0, 100.0);
  o.min_fit = node.getDouble("min_fit", o.min_fit, 0.0, 1.0);
  o.point_cell_size = node.getDouble("point_cell_size", o.point_cell_size, 0.0, 1.0);
  o.point_refinement_whole_floor =
      node.get<bool>("point_refinement_whole_floor", o.point_refinement_whole_floor);
  o.joint_alignment_both_directions =
      node.get<bool>("joint_alignment_both_directions", o.joint_alignment_both_directions);
  o.local_constraint_translation =
      node.get<bool>("local_constraint_translation", o.local_constraint_translation);
  o.point_normal_radius = node.getDouble("point_normal_radius", o.point_normal_radius, 0.01, 5.0);
  o.point_correspondence_distance =
      node.getDouble("point_correspondence_distance", o.point_correspondence_distance, 1e-3, 10.0);
  o.point_robust_distance =
      node.getDouble("point_robust_distance", o.point_robust_distance, 1e-4, 10.0);
  o.ransac_iterations = node.getInt("ransac_iterations", o.ransac_iterations, 1, 10000000);
  o.ransac_translation_tolerance =
      node.getDouble("ransac_translation_tolerance", o.ransac_translation_tolerance, 1e-4, 100.0);
  o.ransac_rotation_tolerance =
      node.getDouble("ransac_rotation_tolerance", o.ransac_rotation_tolerance, 1e-5, M_PI);
  o.ransac_distortion = node.getDouble("ransac_distortion", o.ransac_distortion, 0.0, 0.1);
  o.min_constraints = node.getInt("min_constraints", o.min_constraints, 1, 100000);
  o.ambiguity_ratio = node.getDouble("ambiguity_ratio", o.ambiguity_ratio, 0.0, 1.0);
  o.ambiguity_fit_margin = node.getDouble("ambiguity_fit_margin", o.ambiguity_fit_margin, 0.0, 1.0);
  o.constraint_sigma_xy = node.getDouble("constraint_sigma_xy", o.constraint_sigma_xy, 1e-6, 100.0);
  o.constraint_sigma_theta =
      node.getDouble("constraint_sigma_theta", o.constraint_sigma_theta, 1e-6, M_PI);
  o.normal_tilt_stddev = node.getDouble("normal_tilt_stddev", o.normal_tilt_stddev, 0.0, 1.0);
  o.max_weak_sigma = node.getDouble("max_weak_sigma", o.max_weak_sigma, 0.0, 100.0);
  o.self_check = node.get<bool>("self_check", o.self_check);
  o.match_self_similar = node.get<bool>("match_self_similar", o.match_self_similar);
  o.match_both_directions = node.get<bool>("match_both_directions", o.match_both_directions);
  o.backwards_sequences = node.get<bool>("backwards_sequences", o.backwards_sequences);
  o.wall_recheck = node.getDouble("wall_recheck", o.wall_recheck, 0.0, 1.0);
  o.same_floor_see_through =
      node.getDouble("same_floor_see_through", o.same_floor_see_through, 0.0, 1.0);
  o.same_floor_through_beams =
      node.getInt("same_floor_through_beams", o.same_floor_through_beams, 1, 10000);
  o.floor_change.radius = node.getDouble("floor_change_radius", o.floor_change.radius, 0.0, 1e4);
  o.floor_change.heading =
      node.getDouble("floor_change_heading", o.floor_change.heading, 0.0, M_PI);
  o.wall_beams = node.getInt("wall_beams", o.wall_beams, 1, 10000);
  o.wall_recheck_max = node.getInt("wall_recheck_max", o.wall_recheck_max, 0, 1000000);
  o.wall_log_p = node.getDouble("wall_log_p", o.wall_log_p, -100.0, 0.0);
  o.threads = node.getInt("threads", o.threads, 1, 256);
  o.seed =
      static_cast<std::uint64_t>(node.get<std::int64_t>("seed", static_cast<std::int64_t>(o.seed)));
  node.finish();
  return o;
}

const char* candidateStatusName(CandidateStatus status) {
  switch (status) {
    case CandidateStatus::kAccepted:
      return "accepted";
    case CandidateStatus::kLowLikelihood:
      return "low_likelihood";
    case CandidateStatus::kPoorFit:
      return "poor_fit";
    case CandidateStatus::kOutlier:
      return "outlier";
    case CandidateStatus::kTooFew:
      return "too_few";
    case CandidateStatus::kAmbiguous:
      return "ambiguous";
    case CandidateStatus::kUnderconstrained:
      return "underconstrained";
    case CandidateStatus::kContradicted:
      return "contradicted";
  }
  return "unknown";
}

const PairResult* MatchResult::pairFor(int graph_id) const {
  const PairResult* last = nullptr;
  for (const auto& p : pairs) {
    if (p.graph_id != graph_id) continue;
    if (p.accepted) return &p;
    last = &p;
  }
  return last;
}

}  // namespace storey::matching
