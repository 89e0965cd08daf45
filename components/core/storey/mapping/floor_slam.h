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
#include "storey/mapping/floor_slam_options.h"
#include "storey/mapping/global_relocalizer.h"
#include "storey/mapping/scan_matcher.h"
#include "storey/mapping/tracker.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping {

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
  bool matched = false;  // the scan matched the local map
  double score = 0.0;    // its mean score there (correlative)
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
  std::size_t successor_matches = 0;  // edges from matching a node against its successors
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
  // Whether `scan` matches the recent nodes' map where odometry puts it from the last
  // tracked scan, in the tracker's window and with the score loop closures need: the robot
  // is still on this floor, where tracking left it. Changes nothing.
  bool continuesHere(const sensor::LaserScan& scan, const geometry::Pose2& odometry);
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
