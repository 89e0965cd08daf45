// Sequence localisation: preparing a floor (maps, learned l_min), replaying scan
// sequences in another floor's map with the particle filter, and the candidate gate.
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

PreparedFloor prepareFloor(const floor::FloorGraph& graph, const FloorMatcherOptions& options) {
  PreparedFloor p;
  p.graph = &graph;
  const grid::OccupancyGrid grid = floor::renderFloorMap(graph, options.map);
  p.map = std::make_unique<LocalizationMap>(grid, options.likelihood_field);
  p.structure = p.map->occupiedCells();
  if (options.point_cell_size > 0.0)
    p.points = grid::PointMap(
        floor::floorPoints(graph, 0, graph.nodes.size(), options.map.max_insert_range),
        options.point_cell_size, options.point_normal_radius);
  p.l_min = learnLikelihoodThreshold(
      graph, options, mixSeed(options.seed, 0x1EA2, static_cast<std::uint64_t>(graph.graph_id)));
  return p;
}

double learnLikelihoodThreshold(const floor::FloorGraph& graph, const FloorMatcherOptions& options,
                                std::uint64_t seed) {
  if (graph.nodes.size() < 2) return 0.0;
  floor::FloorGraph even;
  for (std::size_t n = 0; n < graph.nodes.size(); n += 2) even.nodes.push_back(graph.nodes[n]);
  const LocalizationMap map(floor::renderFloorMap(even, options.map), options.likelihood_field);
  ParticleFilter filter(map, options.filter, seed);
  const double sigma_xy = 0.05, sigma_theta = 0.02;
  filter.initializeAround(graph.nodes.front().pose, sigma_xy, sigma_theta,
                          options.learning_particles);
  std::vector<double> values;
  for (std::size_t n = 0; n < graph.nodes.size(); ++n) {
    // Moved by the graph's own relative poses (the mapper knows them): the raw odometry
    // can jump, e.g. across an elevator ride between two visits of the floor, and a lost
    // tracker would teach a meaningless l_min.
    if (n > 0) filter.predict(graph.nodes[n - 1].pose.between(graph.nodes[n].pose));
    const double lt = filter.update(graph.nodes[n].scan);
    if (n % 2 == 1) values.push_back(lt);
    filter.resampleIfNeeded();
  }
  // A tracker that lost its way for a while (a long featureless corridor) must not drag
  // the threshold to nothing: l_min is at least half the median.
  return std::max(quantile(values, options.likelihood_quantile), 0.5 * quantile(values, 0.5));
}

namespace {

// One sequence: `filter` (already initialised) replays the scans at replay positions
// kp, kp+1, ... (node indices `at`) until it converges after at least min_sequence scans
// or max_sequence scans have been used.
struct SequenceRun {
  bool converged = false;
  int mp = 0;  // replay position of the last scan used
  double lt = 0.0;
  FilterState state;
};

template <typename At>
SequenceRun runSequence(ParticleFilter* filter, const floor::FloorGraph& g, At at, int kp,
                        const FloorMatcherOptions& o) {
  const int count = static_cast<int>(g.nodes.size());
  const int end = std::min(count, kp + o.max_sequence);
  SequenceRun run;
  for (run.mp = kp; run.mp < end; ++run.mp) {
    const int n = at(run.mp);
    if (run.mp > kp)
      filter->predict(g.nodes[at(run.mp - 1)].first_pose.between(g.nodes[n].first_pose));
    run.lt = filter->update(g.nodes[n].scan);
    run.state = filter->state();
    if (run.mp - kp + 1 >= o.min_sequence && run.state.converged) {
      run.converged = true;
      return run;
    }
    filter->resampleIfNeeded();
  }
  run.mp = std::max(kp, end - 1);
  return run;
}

// The candidate of a converged sequence from node k = at(kp) to m = at(mp): refined,
// back-propagated to k, gated.
template <typename At>
Candidate makeCandidate(const PreparedFloor& map_floor, const PreparedFloor& scans_floor,
                        double l_min, const FloorMatcherOptions& o, bool backwards, At at, int kp,
                        const SequenceRun& run) {
  const floor::FloorGraph& ref = *map_floor.graph;
  const floor::FloorGraph& g = *scans_floor.graph;
  const int k = at(kp), m = at(run.mp);
  const int first = std::min(k, m), last = std::max(k, m);
  Candidate c;
  c.reference_graph_id = ref.graph_id;
  c.graph_id = g.graph_id;
  c.first_index = first;
  c.last_index = last;
  c.backwards = backwards;
  c.node_index = k;
  c.node_id = g.nodes[k].id;
  c.estimate = run.state.mean;
  c.likelihood = run.lt;
  c.l_min = l_min;
  c.particles = run.state.particles;
  c.mass_within = run.state.mass_within;
  c.dz = g.floor_height - ref.floor_height;
  Pose2 alignment = run.state.mean * g.nodes[m].pose.inverse();
  c.fit = refineAlignment(map_floor.map->field(), g, {{first, last}}, o.refine_beams,
                          o.refine_iterations, &alignment);
  c.alignment = alignment;
  const Pose2 refined_m = alignment * g.nodes[m].pose;
  c.refine_correction = (refined_m.translation() - run.state.mean.translation()).norm();
  const Pose2 x_k = alignment * g.nodes[k].pose;
  const int q = ref.nearestNodeIndex(x_k.translation());
  c.reference_node_id = ref.nodes[q].id;
  c.measurement = ref.nodes[q].pose.between(x_k);
  if (!map_floor.points.empty()) {
    const std::vector<Eigen::Vector2d> points =
        floor::floorPoints(g, static_cast<std::size_t>(first), static_cast<std::size_t>(last) + 1,
                           o.map.max_insert_range);
    grid::PointAlignmentOptions a;
    a.max_iterations = 0;  // the information where the candidate is
    a.max_correspondence_distance = o.point_correspondence_distance;
    a.robust_distance = o.point_robust_distance;
    const grid::PointAlignment fit = grid::alignToPoints(map_floor.points, points, alignment, a);
    // Conditioning where the scans are, not at g_i's origin (often tens of metres away).
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const auto& p : points) centre += p;
    if (!points.empty())
      centre = alignment.transformPoint(centre / static_cast<double>(points.size()));
    const grid::TranslationConditioning cond = grid::translationConditioning(
        grid::withoutNormalNoise(fit.information, o.normal_tilt_stddev),
        alignment.translation() - centre);
    c.information_ratio = cond.ratio;
    c.weak_direction = std::atan2(cond.weak_direction.y(), cond.weak_direction.x());
  }
  const double weak_sigma = c.information_ratio > 0.0
                                ? o.constraint_sigma_xy / std::sqrt(c.information_ratio)
                                : std::numeric_limits<double>::infinity();
  if (run.lt < l_min) {
    c.status = CandidateStatus::kLowLikelihood;
    c.reason = common::str("l_t ", run.lt, " < l_min ", l_min);
  } else if (c.refine_correction > o.max_refine_correction || c.fit < o.min_fit) {
    c.status = CandidateStatus::kPoorFit;
    c.reason = common::str("refinement moved ", c.refine_correction, " m, fit ", c.fit);
  } else if (o.max_weak_sigma > 0.0 && c.information_ratio >= 0.0 &&
             weak_sigma > o.max_weak_sigma) {
    c.status = CandidateStatus::kUnderconstrained;
    c.reason = common::str("its scans pin one direction to sigma ", weak_sigma, " m > ",
                           o.max_weak_sigma, " (information ratio ", c.information_ratio, ")");
  } else {
    c.status = CandidateStatus::kOutlier;  // decided by RANSAC
  }
  return c;
}

}  // namespace

namespace detail {

int recheckWalls(const PreparedFloor& map_floor, const PreparedFloor& scans_floor, double l_min,
                 const FloorMatcherOptions& o, std::uint64_t seed, Candidate* c,
                 PairResult* counters, std::uint64_t* evaluations) {
  const floor::FloorGraph& g = *scans_floor.graph;
  const int count = static_cast<int>(g.nodes.size());
  const bool backwards = c->backwards;
  auto at = [&](int position) { return backwards ? count - 1 - position : position; };
  const int kp = backwards ? count - 1 - c->node_index : c->node_index;
  const int mp_before = backwards ? count - 1 - c->first_index : c->last_index;
  if (c->status != CandidateStatus::kOutlier) return mp_before;
  c->see_through = seeThroughFraction(map_floor.map->frame(), map_floor.walls(o), g,
                                      {{c->first_index, c->last_index}}, o.refine_beams,
                                      c->alignment, kWallMargin);
  if (c->see_through <= o.wall_recheck) return mp_before;
  if (counters->wall_rechecks >= o.wall_recheck_max) {
    // Unrelated floors give many candidates that see through walls; each recheck is a
    // global localisation with traced beams. Past the budget, such a candidate is dropped:
    // it was suspect, and dropping evidence never adds a wrong constraint.
    c->status = CandidateStatus::kPoorFit;
    c->reason = common::str("sees through walls (", c->see_through, " of beams); ",
                            o.wall_recheck_max, " rechecks already spent on this pair");
    return mp_before;
  }
  ++counters->wall_rechecks;
  ParticleFilter filter(*map_floor.map, o.filter,
                        seed ^ (0x3A11ULL + 977ULL * static_cast<std::uint64_t>(kp)));
  filter.setWallModel(&map_floor.wallModel(o), o.wall_beams, o.wall_log_p, kWallMargin);
  filter.initializeUniform();
  const SequenceRun run = runSequence(&filter, g, at, kp, o);
  *evaluations += filter.beamEvaluations();
  const double first_through = c->see_through;
  if (!run.converged) {
    c->status = CandidateStatus::kPoorFit;
    c->reason = common::str("sees through walls (", first_through,
                            " of beams) and the wall model does not converge");
    return mp_before;
  }
  *c = makeCandidate(map_floor, scans_floor, l_min, o, backwards, at, kp, run);
  c->see_through = seeThroughFraction(map_floor.map->frame(), map_floor.walls(o), g,
                                      {{c->first_index, c->last_index}}, o.refine_beams,
                                      c->alignment, kWallMargin);
  c->reason = common::str("re-localised with the wall model (the first estimate saw through ",
                          first_through, " of beams)", c->reason.empty() ? "" : "; ", c->reason);
  return std::max(mp_before, run.mp);
}

std::vector<Candidate> localiseSequences(const PreparedFloor& map_floor,
                                         const PreparedFloor& scans_floor, double l_min,
                                         const FloorMatcherOptions& o, std::uint64_t seed,
                                         bool backwards, bool walls, PairResult* counters,
                                         std::uint64_t* evaluations) {
  const floor::FloorGraph& ref = *map_floor.graph;
  const floor::FloorGraph& g = *scans_floor.graph;
  const int count = static_cast<int>(g.nodes.size());
  auto at = [&](int position) { return backwards ? count - 1 - position : position; };
  std::vector<Candidate> out;
  ParticleFilter filter(*map_floor.map, o.filter, seed ^ (backwards ? 0xBAC5EEDULL : 0x5EEDULL));
  int kp = 0;  // positions in replay order; at() gives the node index
  while (kp + o.min_sequence <= count && !ref.nodes.empty()) {
    ++counters->sequences;
    filter.initializeUniform();
    const SequenceRun run = runSequence(&filter, g, at, kp, o);
    if (!run.converged) {
      ++counters->not_converged;
      kp += o.restart_stride;
      continue;
    }
    Candidate c = makeCandidate(map_floor, scans_floor, l_min, o, backwards, at, kp, run);
    int mp = run.mp;
    if (walls) mp = recheckWalls(map_floor, scans_floor, l_min, o, seed, &c, counters, evaluations);
    out.push_back(std::move(c));
    kp = mp + 1;
  }
  *evaluations += filter.beamEvaluations();
  return out;
}

Candidate reverseCandidate(const Candidate& r, const floor::FloorGraph& ref,
                           const floor::FloorGraph& g) {
  Candidate c = r;
  c.reversed = true;
  c.reference_graph_id = ref.graph_id;
  c.graph_id = g.graph_id;
  c.alignment = r.alignment.inverse();
  c.dz = -r.dz;
  // r.node_id is node k of g_ref, r.reference_node_id the nearest node q of g_i, and
  // r.measurement is node k in node q's frame.
  int q = 0;
  while (q < static_cast<int>(g.nodes.size()) && g.nodes[q].id != r.reference_node_id) ++q;
  c.node_index = q;
  c.node_id = r.reference_node_id;
  c.reference_node_id = r.node_id;
  c.measurement = r.measurement.inverse();
  return c;
}

}  // namespace detail

}  // namespace storey::matching
