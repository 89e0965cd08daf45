// What FloorSlam's source files share: its state (FloorSlam::Impl) and the helpers its
// tracking, loop closures and relocalisation all use. Not part of the library's interface.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "storey/floor/floor_graph.h"
#include "storey/graph/optimizer.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/mapping/floor_slam.h"

namespace storey::mapping {

namespace detail {

constexpr int kWideSearchLevels = 7;  // pyramid depth for loop closure and relocalisation

graph::EdgeKind toGraphKind(floor::EdgeKind kind);
// The information of `covariance`, or none where it is not positive definite.
Eigen::Matrix3d safeInformation(const Eigen::Matrix3d& covariance);
graph::OptimizerOptions withoutRobustKernels(graph::OptimizerOptions options);
double largestTranslationStddev(const Eigen::Matrix3d& covariance);
// The matched step from the last node, with its position along each direction where the
// match's information is below `ratio` times the odometry step's replaced by the two fused
// by their information (at the match's heading).
geometry::Pose2 withOdometryWhereDegenerate(const geometry::Pose2& matched,
                                            const Eigen::Matrix3d& match_information,
                                            const geometry::Pose2& odometry,
                                            const Eigen::Matrix3d& odometry_information,
                                            double ratio);
// The odometry step's information restricted to the horizontal directions where the
// match's information is below `ratio` times the odometry's (zero elsewhere and in heading).
Eigen::Matrix3d odometryWhereDegenerate(const Eigen::Matrix3d& match_information,
                                        const Eigen::Matrix3d& odometry_information, double ratio);
// Whether `covariance` spans `offset` within sigma_factor standard deviations along it.
bool pinsAlong(const Eigen::Matrix3d& covariance, const Eigen::Vector2d& offset,
               double sigma_factor);

// The map of the graph's nodes `indices` (or [first, last)) for `matcher` (see floor_slam.cpp).
MatchTarget buildTarget(const floor::FloorGraph& graph, const std::vector<std::size_t>& indices,
                        const LocalMapOptions& o, int pyramid_levels, const ScanMatcher& matcher,
                        grid::OccupancyGrid* grid_out = nullptr);
MatchTarget buildTarget(const floor::FloorGraph& graph, std::size_t first, std::size_t last,
                        const LocalMapOptions& o, int pyramid_levels, const ScanMatcher& matcher,
                        grid::OccupancyGrid* grid_out = nullptr);
std::vector<Eigen::Vector2d> pointsWhereObserved(const std::vector<Eigen::Vector2d>& points,
                                                 const geometry::Pose2& pose,
                                                 const grid::OccupancyGrid& grid);
MatchTarget buildLocalTarget(const floor::FloorGraph& graph, const LocalMapOptions& o,
                             const ScanMatcher& matcher);

}  // namespace detail

struct FloorSlam::Impl {
  explicit Impl(const FloorSlamOptions& o)
      : tracker(o.odometry, TrackingWindows{o.matcher.linear_window, o.matcher.angular_window,
                                            o.max_linear_window, o.max_angular_window,
                                            o.node.min_translation, o.node.min_rotation}),
        matcher(o.matcher),
        loop_matcher(o.loop_closure.matcher),
        optimizer(o.optimizer),
        full_weight_optimizer(detail::withoutRobustKernels(o.optimizer)) {
    ScanMatcherOptions reloc = o.loop_closure.matcher;
    reloc.angular_step = o.relocalization.angular_step;
    reloc.min_score = o.relocalization.min_score;
    reloc.translation_penalty = 0.0;
    reloc.rotation_penalty = 0.0;
    reloc.max_lookups = 0.0;  // a search of the whole floor, made once per arrival
    reloc_matcher = ScanMatcher(reloc);
    ScanMatcherOptions loop = o.loop_closure.matcher;
    loop.min_score = std::min(loop.min_score, o.loop_closure.min_score);
    loop_matcher = ScanMatcher(loop);
    ScanMatcherOptions polish = loop;
    polish.point_refinement = true;
    polish_matcher = ScanMatcher(polish);
    loop.translation_penalty = 0.0;  // a cluster's rival anywhere in the region counts alike
    loop.rotation_penalty = 0.0;
    loop.min_score = 0.05;  // scores are compared with each other, not with a bar
    verify_matcher = ScanMatcher(loop);
  }
  Tracker tracker;
  ScanMatcher matcher;
  ScanMatcher loop_matcher;
  ScanMatcher polish_matcher;  // the loop matcher's options, refining on points
  ScanMatcher reloc_matcher;
  ScanMatcher verify_matcher;  // a cluster's scans over the region its graph allows
  graph::Optimizer optimizer;
  graph::Optimizer full_weight_optimizer;  // a cluster's correction first, before the kernels
  MatchTarget local_target;
  bool local_dirty = true;
  int nodes_since_rebuild = 0;
  MatchTarget floor_target;  // whole floor, for relocalisation
  bool floor_target_valid = false;
  // The last loop-closure attempt's candidate map: nodes [first, end) around `centre`, at
  // the poses they had when it was built.
  struct LoopTarget {
    MatchTarget target;
    std::size_t first = 0, end = 0;
    int centre = -1;
    std::vector<geometry::Pose2> poses;
  } loop_target;

  bool have_last = false;
  double last_stamp = 0.0;
  std::size_t beam_count = 0;
  // Whether the odometry agreed with the matches at the last node (tracker.h): the odometry
  // between two such nodes is an edge; a step into or out of a stall is not.
  bool last_node_odometry_agrees = true;
  std::size_t chain_start = 0;          // first node of the current run of tracked nodes
  std::vector<std::size_t> run_starts;  // every such first node, in order
  std::size_t successors_matched = 0;   // nodes before this one were tried (at finish)
  int nodes_since_attempt = 0;
  // Relocalisation state.
  geometry::Pose2 reloc_guess;
  bool reloc_have_odometry = false;
  geometry::Pose2 reloc_odometry;
  int reloc_attempts = 0;
  // Each step between consecutive nodes (k -> k+1, in node k's frame) as its edges
  // measured it: their information and information-weighted measurements, whose quotient is
  // the step's fused measurement. Closures are checked against each other through chains of
  // these, not through the nodes' current poses: between optimisations the poses are the
  // tracker's, which in a bare corridor may not have moved where odometry did.
  struct Step {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  };
  std::vector<Step> steps;
  // Matched closures within the cluster window, held or accepted: the attempts (indices
  // into loop_attempts_, which hold their nodes, measurement and information).
  struct Hypothesis {
    std::size_t attempt = 0;
    bool accepted = false;
  };
  std::vector<Hypothesis> hypotheses;
  // Pending update.
  std::size_t update_nodes_from = 0;
  std::vector<floor::FloorEdge> update_edges;
  bool poses_changed = false;
};

}  // namespace storey::mapping
