// The per-floor SLAM front end: one floor graph grown from scans and odometry.
//
// Each scan is predicted from odometry; when the robot has moved or turned enough since
// the last node, the scan is matched against a local map (the recent nodes' scans in an
// occupancy grid, as a likelihood field) and becomes a node, joined to the previous node
// by an odometry edge and a scan-match edge whose information comes from the match.
// Every few nodes, older nodes within the current pose's uncertainty (marginal covariance
// from the optimiser, grown along the chain since) are loop-closure candidates: the scan
// is matched in a map around the candidate, a good match becomes a loop-closure edge
// (robust kernel), the graph is re-optimised, and a closure the optimised graph disagrees
// with is disabled again.
//
//   FloorSlam slam(readFloorSlamOptions(config), "robot1", /*graph_id=*/0, /*floor_id=*/0, 0.0);
//   for (...) slam.addScan(scan, odometry_pose_at_scan_time);
//   slam.floorGraph();   // nodes (pose, odometry, scan) and edges
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/floor/floor_graph.h"
#include "storey/graph/optimizer.h"
#include "storey/graph/pose_graph.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/mapping/closure_clusters.h"
#include "storey/mapping/global_relocalizer.h"
#include "storey/mapping/scan_matcher.h"
#include "storey/mapping/tracker.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping {

struct NodeCreationOptions {
  double min_translation = 0.2;  // m since the last node
  double min_rotation = 0.17;    // rad since the last node
};

struct LocalMapOptions {
  int max_nodes = 20;  // most recent nodes rendered into the local map
  double resolution = 0.05;
  double max_insert_range = 20.0;  // m; farther returns are left out of local maps
  int pyramid_levels = 5;  // enough for the tracking window; wider searches start coarser
  int rebuild_every_n_nodes = 2;  // the local map is re-rendered this often
  // A scan the local map does not match is matched again against the map of only the last
  // retry_nodes nodes (0, or not below max_nodes: off). Drift within the local map puts its far
  // end's walls beside the near end's, and each copy's rays erase the other's cells: a robot that
  // moves 1 m per scan down a corridor (infinite-corridor) then fails runs of matches that the last
  // few scans alone would take (docs/floor_mapper.md, "A second try on the last nodes").
  int retry_nodes = 5;
  // The scans' points, averaged per cell of this size, refine matches below the grid's
  // resolution (ScanMatcher::refineOnPoints); 0: refine on the likelihood field.
  double point_cell_size = 0.05;
  double point_normal_radius = 0.2;  // m, neighbourhood of a point's surface normal
  grid::LikelihoodFieldOptions field;
};

struct LoopClosureOptions {
  bool enabled = true;
  int every_n_nodes = 3;         // attempt a closure every n nodes
  int min_node_gap = 40;         // candidates are at least this many nodes older
  double search_radius = 1.5;    // m, plus sigma_factor standard deviations
  double sigma_factor = 3.0;
  double max_search_radius = 10.0;
  double linear_window = 1.0;   // m, plus sigma_factor standard deviations...
  double max_linear_window = 4.0;  // ...up to this
  double angular_window = 0.35;  // rad, plus sigma_factor standard deviations...
  double max_angular_window = 1.2;  // ...up to this
  int submap_half_nodes = 10;    // the candidate's map: nodes within this index distance
  // The last attempt's candidate map is reused while none of its nodes has moved and the new
  // candidate is at most this many nodes from its centre (building it costs more than the
  // match); 0: only for the same candidate.
  int submap_reuse_nodes = 5;
  double min_score = 0.6;        // refined mean score a closure needs
  double max_chi2 = 25.0;        // after optimisation, a closure with larger χ² is disabled
  // A closure whose scan fits as well (ambiguity_ratio of its correlative score) at a place
  // more than ambiguity_distance away in the search window is ambiguous along the line
  // between the two (a corridor's repeating doors): it keeps its information across that
  // line and in heading, none along it. 0: no check.
  double ambiguity_distance = 0.0;  // m
  double ambiguity_ratio = 0.9;
  // Closures that agree with each other (closure_clusters.h). A matched closure the graph
  // does not already agree with (χ² after a robust optimisation) is held as a hypothesis;
  // when cluster_size hypotheses and accepted closures whose newer nodes lie within
  // cluster_window nodes agree pairwise (cycle χ² <= cluster_chi2 through the chains
  // between them), the held ones go in together: optimised at full weight first (a robust
  // kernel would refuse the correction they bring), then robustly, and kept when each
  // edge's χ² is <= max_chi2. 0 or 1: no hypotheses, a closure stands or falls alone.
  int cluster_size = 3;
  int cluster_window = 60;    // nodes
  double cluster_chi2 = 11.34;  // χ²(3 dof) at 99 %
  // A cluster ties older nodes at least this far apart (m): matches against one small
  // place share its ambiguity (a bare corridor's corner fits a scan 2 m off match after
  // match, and such matches agree with each other).
  double cluster_min_spread = 1.0;
  // A closure alone (no cluster) may move its nodes only this far from where the graph has
  // them (a graph uncertain enough bends to fit a wrong closure with χ² near 0:
  // infinite-corridor accepted one 5.6 m off so); larger corrections need a cluster.
  // Only when cluster_size > 1.
  double single_max_translation = 0.5;  // m
  double single_max_rotation = 0.1;     // rad
  // A cluster is checked against the whole region the graph's uncertainty allows (a
  // look-alike stretch of corridor fits a consistently shifted set of matches, which then
  // agree with each other): the newest closure's scan and the cluster_verify_nodes before it,
  // placed relative to each other by the graph, are searched over the old map within
  // min(cluster_verify_window, linear_window + sigma_factor σ) of where the graph has them,
  // with no penalty for the distance. When a pose more than cluster_verify_distance from the
  // cluster's scores cluster_verify_ratio of the best near it, the cluster is refused; when
  // it scores better, the newest closure is moved there (its scan matched at that place, to
  // the old node nearest it) and may form a cluster with others so moved. 0: no check.
  double cluster_verify_window = 0.0;  // m
  double cluster_verify_distance = 4.0;  // m
  double cluster_verify_ratio = 1.0;
  int cluster_verify_nodes = 20;
  // While a closure the check moved is held, attempts search around the pose it gives the
  // robot (its place, then the chain of steps since), not the graph's, which is farther off
  // than the window reaches when the check had to move it.
  bool follow_relocated = false;
  // While the window is at its cap (max_linear_window), or from single_unique_window on
  // (below), a closure goes in alone (a small correction) only when no pose more than
  // single_unique_distance from its match scores single_unique_ratio of it in the window,
  // unless its own covariance spans that pose (sigma_factor σ along the line to it: a bare
  // corridor's axis); otherwise it is held for a cluster. 0: off.
  double single_unique_distance = 0.0;  // m
  double single_unique_ratio = 0.9;
  // The uniqueness check runs from this window on, when below max_linear_window (0: only
  // at the cap): a wider cap lets long loops close, but a window of 10-20 m still holds
  // a corridor's look-alike near a prediction that far off.
  double single_unique_window = 0.0;  // m
  // A closure's pose from the likelihood field is then refined on the candidate map's
  // points (point-to-line, as tracking) and the refined pose is kept when it moved at most
  // this far; its covariance stays the field's. In a 2 m elevator cabin the field's
  // refinement left closures about 1 deg off, all to one side (docs/floor_mapper.md,
  // session 18). 0: off.
  double point_polish_translation = 0.0;  // m
  double point_polish_rotation = 0.0;     // rad
  // For closures (windows from the options above). They refine on the likelihood field
  // (ScanMatcherOptions::point_refinement false): on the points, closures in the ring
  // corridor of FloorSlam.LoopClosureCorrectsDrift landed 1.5-1.9 m wrong.
  ScanMatcherOptions matcher;
};

struct RelocalizationOptions {
  // Local search (FloorSlam::resumeAt: an aborted ride, back on the floor it left).
  double linear_window = 3.0;    // m around the expected arrival point
  double angular_window = M_PI;  // rad
  double angular_step = 0.01;    // rad
  double min_score = 0.6;
  int max_attempts = 10;  // scans tried before resuming on the guess alone
  // Arriving on a floor mapped before: "relocalize" localises the arriving scans globally
  // in that floor's map (GlobalRelocalizer: the matcher's particle filter, then a
  // refinement and uniqueness check) and resumes the old graph there; when that does not
  // succeed it falls back to "new_graph": a new graph of the floor, aligned later by the
  // floor matcher.
  std::string known_floor = "relocalize";
  GlobalRelocalizationOptions global;
};

struct FloorSlamOptions {
  ScanMatcherOptions matcher;
  NodeCreationOptions node;
  LocalMapOptions local_map;
  OdometryNoiseModel odometry;
  LoopClosureOptions loop_closure;
  RelocalizationOptions relocalization;
  graph::OptimizerOptions optimizer;
  // The tracking window's cap (its floor is the matcher's window; between them 3 σ of the
  // prediction: tracker.h).
  double max_linear_window = 1.5;        // m
  double max_angular_window = M_PI / 2;  // rad: a corridor turned half round fits as well
  // Along a direction where the scan match's information is below degenerate_ratio times
  // the odometry step's (a bare corridor's axis), a new node's position is the two fused
  // by their information, not the match's alone (solution remapping for degenerate
  // directions). 0: the match's position always.
  double degenerate_ratio = 0.1;
  // Scans stamped after a ride's end but before the detector decided it (the robot is
  // often out of the cabin by then, looking at the landing that floors share) start the
  // graph of a floor reached for the first time (FloorSessions; not a relocalisation in
  // a known floor, where the cabin looks like any shaft); false drops them as in transit.
  bool map_arrival_scans = true;
  // Once a node has successor_match_nodes tracked nodes after it, its scan is also matched
  // against their map, and the match becomes an edge from the next node back to it. The
  // tracking edge measures a step from the scans before it, this one from the scans
  // after it (csail, intel, infinite-corridor: nearby rotation 10-25 % lower). Both reuse
  // the same scans, so this edge's information is scaled by successor_match_weight.
  // 0: off (docs/floor_mapper.md, "Scans after a node").
  int successor_match_nodes = 0;
  double successor_match_weight = 0.5;
  // Match the nodes against their successors when the graph is finished (finish(): end of
  // input, leaving the floor), at its final poses, instead of as the nodes come. Then every
  // loop closure is decided on the tracking graph alone: matched as they come, these edges
  // bent infinite-corridor's long unclosed stretch until its closure window missed the loop.
  bool successor_match_at_finish = false;
};
// Reads the front end's options (all keys optional; unknown keys are errors). Sections:
// scan_matcher, node_creation, local_map (with likelihood_field), odometry_noise,
// loop_closure (with scan_matcher), relocalization, optimizer.
FloorSlamOptions readFloorSlamOptions(const common::ConfigNode& node);

enum class ScanStatus {
  kNode,      // became a node
  kSkipped,   // not enough motion since the last node; pose predicted from odometry
  kRejected,  // bad input (see reason); nothing changed
};
const char* scanStatusName(ScanStatus status);

struct ScanResult {
  ScanStatus status = ScanStatus::kRejected;
  std::string reason;
  geometry::Pose2 pose;  // estimated robot pose in the floor frame
  int node_id = -1;
  bool matched = false;       // the scan matched the local map
  double score = 0.0;         // its mean score there (correlative)
  // Whether it was found where the odometry's motion since it last agreed put it, around
  // the last tracked pose instead of where odometry put it, and whether the odometry agreed
  // with the match.
  bool caught_up = false, wide = false, odometry_agrees = true;
  bool loop_closed = false;   // a loop closure was accepted with this node
  bool relocalized = false;   // resumed a known floor with this scan
};

// What changed since the last takeUpdate(): for publishing incrementally.
struct GraphUpdate {
  std::vector<floor::FloorNode> new_nodes;
  std::vector<floor::FloorEdge> new_edges;
  bool poses_changed = false;  // optimised: every node's pose may have moved
};

// One loop-closure attempt and what became of it (provenance: storey slam writes them).
enum class LoopOutcome {
  kNoMatch,       // the scan did not match the candidate's map (or scored below min_score)
  kAccepted,      // added to the graph
  kInconsistent,  // the optimised graph disagreed (chi2 > max_chi2): undone
  kUnconfirmed,   // held as a hypothesis; no cluster of agreeing closures took it (yet)
  kAmbiguous,     // its cluster's scans fit as well or better elsewhere: dropped
};
const char* loopOutcomeName(LoopOutcome outcome);
struct LoopClosureAttempt {
  int node = -1;       // the current node
  int candidate = -1;  // the older node it was matched against
  double score = 0.0;  // refined mean score (0 when nothing matched)
  geometry::Pose2 measurement;  // candidate -> node, when matched
  geometry::Pose2 predicted;    // candidate -> node as the graph had it when attempted
  double linear_window = 0.0, angular_window = 0.0;  // searched around the prediction
  double sigma = 0.0;  // the node's marginal standard deviation (largest axis, m) then
  // The move the measurement asks of the node, in its frame: predicted⁻¹ · measurement.
  geometry::Pose2 correction() const { return predicted.between(measurement); }
  int together = 0;             // closures added with it (1: alone; more: a cluster)
  // Its cluster's scans fitted better elsewhere in the old map; the measurement is that
  // place's (to the old node nearest it), no longer the candidate map's match.
  bool relocated = false;
  // Searched around the pose a held relocated closure gives the robot (follow_relocated),
  // not the graph's prediction.
  bool followed = false;
  // A small correction held for company because another place in the window fitted as well
  // (single_unique_distance).
  bool not_unique = false;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  double chi2 = 0.0;   // after optimisation, when added
  LoopOutcome outcome = LoopOutcome::kNoMatch;
};

struct FloorSlamStats {
  std::size_t scans = 0, nodes = 0, skipped = 0, rejected = 0;
  std::size_t matched = 0, match_failures = 0;
  std::size_t retry_matches = 0;  // scans matched by the retry on the last nodes' map
  // Scans found where the odometry's motion since it last agreed with the scans puts them
  // (stale odometry that caught up).
  std::size_t caught_up_matches = 0;
  std::size_t disagreeing_matches = 0;  // matches the odometry since its anchor disagrees with
  std::size_t wide_matches = 0;  // scans found around the last pose, not where odometry put them
  std::size_t successor_matches = 0;    // edges from matching a node against its successors
  std::size_t loop_attempts = 0, loop_closures = 0, loop_rejected_inconsistent = 0;
  std::size_t loop_ambiguous = 0;  // attempts whose scan fit as well elsewhere
  std::size_t loop_clusters = 0;   // clusters of agreeing closures accepted together
  std::size_t loop_clusters_ambiguous = 0;  // clusters refused: their scans fit as well elsewhere
  std::size_t loop_maps_built = 0;  // candidate maps built (the others were reused)
  std::size_t optimizations = 0;
  std::size_t relocalizations = 0, relocalization_failures = 0;
};

class FloorSlam {
 public:
  FloorSlam(FloorSlamOptions options, std::string robot, int graph_id, int floor_id,
            double floor_height);
  ~FloorSlam();
  FloorSlam(FloorSlam&&) noexcept;
  FloorSlam& operator=(FloorSlam&&) noexcept;

  // One scan and the odometry pose at its stamp. Never throws for bad data: returns
  // kRejected with the reason (and logs it).
  ScanResult addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);

  // Prepares to resume this (non-empty) floor: the next scans are localised in the floor's
  // whole map within the relocalization window around `guess` (e.g. where the robot left
  // the floor: the elevator) before mapping continues.
  void resumeAt(const geometry::Pose2& guess);
  bool awaitingRelocalization() const { return relocalize_; }
  // Resumes this floor after global relocalisation: `scans` (in time order) were recorded
  // since the arrival, and the last of them was localised at `pose` with `covariance`
  // (world frame). The scans that moved enough become a chain of nodes placed by odometry
  // relative to the last; the last is tied to the nearest old node by a scan-match edge
  // (information from `covariance`). Returns the last node's id.
  int resumeLocalized(const std::vector<GlobalRelocalizer::Buffered>& scans, const geometry::Pose2& pose,
                      const Eigen::Matrix3d& covariance);

  const floor::FloorGraph& floorGraph() const { return floor_graph_; }
  const graph::PoseGraph& poseGraph() const { return pose_graph_; }
  const FloorSlamStats& stats() const { return stats_; }
  // Every loop-closure attempt so far, in order.
  const std::vector<LoopClosureAttempt>& loopAttempts() const { return loop_attempts_; }
  const FloorSlamOptions& options() const { return options_; }
  // Last estimated robot pose (of the last accepted scan).
  const geometry::Pose2& currentPose() const { return last_pose_; }
  // Uncertainty of the last node (floor frame).
  const Eigen::Matrix3d& currentCovariance() const { return covariance_; }
  GraphUpdate takeUpdate();
  // Runs the optimiser over the whole graph now.
  void optimize();
  // The graph's input ends for now (end of a log, the robot leaves the floor): with
  // successor_match_at_finish, the nodes not yet matched against their successors are,
  // at the optimised poses; then the graph is optimised.
  void finish();

 private:
  struct Impl;
  // starts_run: no tracked step links it to the node before (first node, odometry jump,
  // relocalisation); successor matches never cross such a node.
  void appendNode(const sensor::LaserScan& scan, const geometry::Pose2& odometry,
                  const geometry::Pose2& pose, bool starts_run);
  std::size_t appendEdge(int from, int to, const geometry::Pose2& measurement,
                         const Eigen::Matrix3d& information, floor::EdgeKind kind);
  ScanResult relocalizeWith(const sensor::LaserScan& scan, const geometry::Pose2& odometry,
                            const std::vector<Eigen::Vector2d>& points);
  bool tryLoopClosure(const std::vector<Eigen::Vector2d>& points);
  // Node index k against the map of the successor_match_nodes nodes after it, as an edge
  // from node k+1 back to k; false when they are not one run of tracked nodes or no match.
  bool matchAgainstSuccessors(std::size_t k);
  // Adds the held hypotheses `members` (indices) as loop-closure edges and optimises
  // (at full weight first when `bend_first`); keeps them when every one's χ² is within
  // max_chi2, else undoes them all. Returns whether they were kept.
  bool addClosures(const std::vector<std::size_t>& members, bool bend_first);
  // The held hypotheses that agree pairwise with the newest, the newest included.
  std::vector<std::size_t> agreeingCluster() const;
  // Whether the cluster's scans fit best where it puts them, within the region the graph's
  // uncertainty allows; if not and a place fits better, the newest node's pose there.
  struct ClusterCheck {
    bool unique = false;
    bool better_elsewhere = false;
    geometry::Pose2 pose;  // of the newest node, where its scans fit better
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  };
  ClusterCheck checkCluster(const std::vector<std::size_t>& cluster, std::size_t last_candidate);
  // Relative pose (with covariance) of node index j in node index i's frame from the
  // odometry and scan-match edges between consecutive nodes (each step their fused
  // measurement); false when a step has no information.
  bool chainBetween(std::size_t i, std::size_t j, UncertainPose* out) const;
  // The map of the nodes around `candidate` (up to last_candidate) for a closure attempt.
  const MatchTarget& loopTarget(int candidate, std::size_t last_candidate);

  std::unique_ptr<Impl> impl_;
  FloorSlamOptions options_;
  floor::FloorGraph floor_graph_;
  graph::PoseGraph pose_graph_;
  FloorSlamStats stats_;
  std::vector<LoopClosureAttempt> loop_attempts_;
  geometry::Pose2 last_pose_;
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
  bool relocalize_ = false;
};

// A covariance of a pose in the world frame re-expressed in the frame of a pose with
// heading `theta` (rotates the translation block).
Eigen::Matrix3d rotateCovariance(const Eigen::Matrix3d& covariance, double theta);

}  // namespace storey::mapping
