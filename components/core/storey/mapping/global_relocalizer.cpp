#include "storey/mapping/global_relocalizer.h"

#include <algorithm>
#include <cmath>

#include "storey/common/log.h"
#include "storey/grid/occupancy_grid.h"

namespace storey::mapping {

using common::str;
using geometry::Pose2;

namespace {

constexpr int kSearchLevels = 7;  // pyramid depth: windows of a few metres start coarse
constexpr int kSectors = 4;       // the whole-map search splits headings into sectors

}  // namespace

struct GlobalRelocalizer::Impl {
  Impl(const grid::OccupancyGrid& grid, const GlobalRelocalizationOptions& o,
       const grid::LikelihoodFieldOptions& match_field, const ScanMatcherOptions& matcher_options)
      : map(grid, o.likelihood_field),
        filter(map, o.filter, o.seed),
        target(grid, match_field, kSearchLevels) {
    ScanMatcherOptions m = matcher_options;
    m.translation_penalty = 0.0;  // no prediction to prefer: the best fit anywhere
    m.rotation_penalty = 0.0;
    m.min_score = 0.0;            // scores are judged here, not by the matcher
    refiner = ScanMatcher(m);
    m.angular_step = 0.01;        // the whole-map search only compares modes
    searcher = ScanMatcher(m);
  }
  localization::LocalizationMap map;
  localization::ParticleFilter filter;
  MatchTarget target;
  ScanMatcher refiner, searcher;
  int fed_since_start = 0;
};

GlobalRelocalizer::GlobalRelocalizer(const floor::FloorGraph& graph,
                                     GlobalRelocalizationOptions options,
                                     ScanMatcherOptions matcher_options,
                                     const grid::LikelihoodFieldOptions& match_field,
                                     double max_insert_range)
    : options_(options) {
  grid::OccupancyGridOptions go;
  go.resolution = options_.map_resolution;
  go.max_insert_range = max_insert_range;
  grid::OccupancyGrid grid(go);
  for (const auto& node : graph.nodes) grid.insertScan(node.scan, node.pose);
  impl_ = std::make_unique<Impl>(grid, options_, match_field, matcher_options);
}

GlobalRelocalizer::~GlobalRelocalizer() = default;

RelocalizationStatus GlobalRelocalizer::add(const sensor::LaserScan& scan, const Pose2& odometry) {
  if (status_ != RelocalizationStatus::kSearching) return status_;
  buffer_.push_back({scan, odometry});
  Impl& s = *impl_;
  if (!fed_.empty()) {
    const Pose2 step = buffer_[fed_.back()].odometry.between(odometry);
    if (step.translation().norm() < options_.feed_translation && std::abs(step.theta()) < options_.feed_rotation) {
      if (static_cast<int>(buffer_.size()) >= options_.max_scans) status_ = RelocalizationStatus::kFailed;
      return status_;
    }
  }
  if (fed_.empty() || s.fed_since_start >= options_.max_sequence || s.fed_since_start == 0) {
    // (Re)start from particles spread over the whole floor.
    s.filter.initializeUniform();
    s.fed_since_start = 0;
    ++result_.filter_runs;
  } else {
    s.filter.predict(buffer_[fed_.back()].odometry.between(odometry));
  }
  fed_.push_back(buffer_.size() - 1);
  ++s.fed_since_start;
  s.filter.update(scan);
  const localization::FilterState state = s.filter.state();
  common::logDebug(str("global_relocalizer: scan ", buffer_.size(), " run ", result_.filter_runs, " fed ",
                       s.fed_since_start, ": ", state.particles, " particles, mass ", state.mass_within, " at (",
                       state.mean.x(), ", ", state.mean.y(), ", ", state.mean.theta(), ")"));
  if (s.fed_since_start >= options_.min_sequence && state.converged) {
    ++result_.candidates;
    if (checkCandidate(state.mean)) {
      status_ = RelocalizationStatus::kLocalized;
      return status_;
    }
    common::logDebug(str("global_relocalizer: candidate (", state.mean.x(), ", ", state.mean.y(), ", ",
                         state.mean.theta(), ") refused: ", result_.last_problem));
    s.fed_since_start = options_.max_sequence;  // restart with the next fed scan
  } else {
    s.filter.resampleIfNeeded();
  }
  if (static_cast<int>(buffer_.size()) >= options_.max_scans) status_ = RelocalizationStatus::kFailed;
  return status_;
}

std::vector<Eigen::Vector2d> GlobalRelocalizer::recentPoints() const {
  std::vector<Eigen::Vector2d> points;
  if (fed_.empty()) return points;
  const Pose2& last_odometry = buffer_[fed_.back()].odometry;
  const std::size_t first = fed_.size() > static_cast<std::size_t>(options_.refine_scans)
                                ? fed_.size() - options_.refine_scans
                                : 0;
  for (std::size_t i = first; i < fed_.size(); ++i) {
    const Buffered& b = buffer_[fed_[i]];
    const Pose2 relative = last_odometry.between(b.odometry);
    for (const auto& p : b.scan.pointsInRobotFrame()) points.push_back(relative.transformPoint(p));
  }
  return points;
}

std::vector<GlobalRelocalizer::Found> GlobalRelocalizer::searchWholeMap(
    const std::vector<Eigen::Vector2d>& sparse) const {
  Impl& s = *impl_;
  std::vector<Found> found;
  const grid::GridFrame& frame = s.target.field().frame();
  const double half = 0.5 * options_.search_tile;
  const double x_end = frame.origin_x + frame.width * frame.resolution;
  const double y_end = frame.origin_y + frame.height * frame.resolution;
  const double sector = M_PI / kSectors;  // half width of one heading sector
  for (double cy = frame.origin_y + half; cy - half < y_end; cy += options_.search_tile) {
    for (double cx = frame.origin_x + half; cx - half < x_end; cx += options_.search_tile) {
      for (int k = 0; k < kSectors; ++k) {
        const Pose2 centre(cx, cy, -M_PI + sector + 2.0 * sector * k);
        const MatchResult r = s.searcher.correlativeSearch(s.target, sparse, centre, half, sector);
        if (r.correlative_score > 0.0) found.push_back({r.pose, r.correlative_score});
      }
    }
  }
  return found;
}

double GlobalRelocalizer::bestFitAnywhere(const std::vector<Eigen::Vector2d>& points) const {
  double best = 0.0;
  for (const auto& f : searchWholeMap(filterPoints(points, options_.search_point_distance)))
    best = std::max(best, f.score);
  return best;
}

bool GlobalRelocalizer::checkCandidate(const Pose2& estimate) {
  Impl& s = *impl_;
  const std::vector<Eigen::Vector2d> points = recentPoints();
  const std::vector<Eigen::Vector2d> dense =
      filterPoints(points, s.refiner.options().point_filter_distance);
  // The filter's estimate, refined; when it does not refine well, the whole-map search
  // below may still find a candidate.
  const MatchResult refined =
      s.refiner.match(s.target, dense, estimate, options_.refine_linear_window, options_.refine_angular_window);
  std::string refine_problem;
  if (!refined.success) {
    refine_problem = str("refinement failed: ", refined.problem);
  } else if (const double correction = (refined.pose.translation() - estimate.translation()).norm();
             correction > options_.max_refine_correction) {
    refine_problem = str("refinement moved the estimate by ", correction, " m");
  } else if (refined.score < options_.min_score) {
    refine_problem = str("refined score ", refined.score, " < ", options_.min_score);
  }
  const bool refined_ok = refine_problem.empty();

  // Uniqueness: the best fit of the same points anywhere on the floor. When a pose
  // elsewhere fits clearly better than the filter's estimate, that pose is the candidate
  // (the filter said the data are distinctive; the search says where), and it must then be
  // unique itself.
  const std::vector<Eigen::Vector2d> sparse = filterPoints(points, options_.search_point_distance);
  const std::vector<Found> found = searchWholeMap(sparse);
  auto near = [&](const Pose2& a, const Pose2& b) {
    return (a.translation() - b.translation()).norm() <= options_.ambiguity_distance &&
           std::abs(geometry::angleDiff(a.theta(), b.theta())) <= options_.ambiguity_angle;
  };
  auto ownScore = [&](const Pose2& pose) {
    double own = s.searcher.correlativeSearch(s.target, sparse, pose, 0.1, 0.05).correlative_score;
    for (const auto& f : found)
      if (near(f.pose, pose)) own = std::max(own, f.score);
    return own;
  };
  MatchResult chosen = refined;
  double own_score = refined_ok ? ownScore(refined.pose) : 0.0;
  const Found* best = nullptr;
  for (const auto& f : found)
    if (!best || f.score > best->score) best = &f;
  if (best && (!refined_ok || (!near(best->pose, refined.pose) && best->score > own_score))) {
    const MatchResult alternative = s.refiner.match(s.target, dense, best->pose, 0.2, 0.1);
    if (!alternative.success || alternative.score < options_.min_score) {
      result_.last_problem = refined_ok ? str("a pose elsewhere fits better (", best->score, " vs ", own_score,
                                              ") but does not refine well")
                                        : refine_problem;
      return false;
    }
    common::logDebug(str("global_relocalizer: the whole-map search prefers (", alternative.pose.x(), ", ",
                         alternative.pose.y(), ", ", alternative.pose.theta(), ") to the filter's estimate (",
                         refined_ok ? "which fits worse" : refine_problem, ")"));
    chosen = alternative;
    own_score = ownScore(alternative.pose);
  } else if (!refined_ok) {
    result_.last_problem = refine_problem;
    return false;
  }
  double best_other = 0.0;
  for (const auto& f : found)
    if (!near(f.pose, chosen.pose)) best_other = std::max(best_other, f.score);
  result_.own = own_score;
  result_.best_other = best_other;
  if (best_other >= options_.ambiguity_ratio * own_score) {
    result_.last_problem = str("ambiguous: a pose elsewhere scores ", best_other, " against ", own_score);
    return false;
  }
  result_.pose = chosen.pose;
  result_.covariance = chosen.covariance;
  result_.score = chosen.score;
  return true;
}

bool GlobalRelocalizer::decideNow() {
  if (status_ != RelocalizationStatus::kSearching) return status_ == RelocalizationStatus::kLocalized;
  if (static_cast<int>(fed_.size()) < options_.min_sequence) return false;
  ++result_.candidates;
  if (checkCandidate(impl_->filter.state().mean)) {
    status_ = RelocalizationStatus::kLocalized;
    return true;
  }
  common::logDebug(str("global_relocalizer: last check refused: ", result_.last_problem));
  return false;
}


}  // namespace storey::mapping
