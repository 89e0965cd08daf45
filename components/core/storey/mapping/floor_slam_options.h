// The per-floor front end's options. A user sets a few keys, the robot's and the sensor's
// models and the map's resolution (config/floor_mapper.yaml's `slam` section, read by
// readFloorSlamOptions); the rest follow from those or are fixed here with their reason.
// The defaults are the shipped file's.
#pragma once

#include <string>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/graph/optimizer.h"
#include "storey/grid/likelihood_field.h"
#include "storey/mapping/global_relocalizer.h"
#include "storey/mapping/scan_matcher.h"
#include "storey/mapping/tracker.h"

namespace storey::mapping {

// What the laser's readings are worth: the standard deviation of a range reading about the
// surface it hit, the walls' own roughness included (a SICK LMS's 1 cm on a real building's
// walls, doors and clutter shows as about 4 cm; a simulated laser's is its noise).
struct LaserModel {
  // m
  double range_noise = shipped_slam::laser::range_noise;
};

struct NodeCreationOptions {
  // m since the last node
  double min_translation = shipped_slam::node_spacing::translation;
  // rad since the last node
  double min_rotation = shipped_slam::node_spacing::rotation;
};

struct LocalMapOptions {
  // most recent nodes rendered into the local map
  int max_nodes = shipped_slam::local_map_nodes;
  double resolution = shipped_slam::map_resolution;
  double max_insert_range = 20.0;  // m; farther returns are left out of local maps
  int pyramid_levels = 5;          // enough for the tracking window; wider searches start coarser
  int rebuild_every_n_nodes = 2;   // the local map is re-rendered this often
  // A scan the local map does not match is matched again against the map of only the last
  // retry_nodes nodes (0, or not below max_nodes: off). Drift within the local map puts its
  // far end's walls beside the near end's, and each copy's rays erase the other's cells: a
  // robot that moves 1 m per scan down a corridor then fails runs of matches that the last
  // few scans alone would take.
  int retry_nodes = 5;
  // The scans' points, averaged per cell of this size, refine tracking matches below the
  // grid's resolution (ScanMatcher::refineOnPoints); 0: refine on the likelihood field.
  double point_cell_size = 0.05;
  double point_normal_radius = 0.2;  // m, neighbourhood of a point's surface normal
  grid::LikelihoodFieldOptions field;
};

struct LoopClosureOptions {
  bool enabled = shipped_slam::loop_closure;
  int every_n_nodes = 3;       // attempt a closure every n nodes
  int min_node_gap = 40;       // candidates are at least this many nodes older
  double search_radius = 1.5;  // m, plus sigma_factor standard deviations...
  double sigma_factor = 3.0;
  double max_search_radius = 20.0;  // ...up to this
  double linear_window = 1.0;       // m, plus sigma_factor standard deviations...
  // ...up to this: after a long loop the right place is farther off than a few metres
  // (infinite-corridor: 10-20 m).
  double max_linear_window = 20.0;
  double angular_window = 0.35;     // rad, plus sigma_factor standard deviations...
  double max_angular_window = 1.2;  // ...up to this
  int submap_half_nodes = 10;       // the candidate's map: nodes within this index distance
  // The last attempt's candidate map is reused while none of its nodes has moved and the new
  // candidate is at most this many nodes from its centre (building it costs more than the
  // match); 0: only for the same candidate.
  int submap_reuse_nodes = 5;
  double min_score = 0.6;  // refined mean score a closure needs
  double max_chi2 = 25.0;  // after optimisation, a closure with larger χ² is disabled
  // Closures that agree with each other (closure_clusters.h). A matched closure the graph
  // does not already agree with (χ² after a robust optimisation) is held as a hypothesis;
  // when cluster_size hypotheses and accepted closures whose newer nodes lie within
  // cluster_window nodes agree pairwise (cycle χ² <= cluster_chi2 through the chains
  // between them), the held ones go in together: optimised at full weight first (a robust
  // kernel would refuse the correction they bring), then robustly, and kept when each
  // edge's χ² is <= max_chi2. 0 or 1: no hypotheses, a closure stands or falls alone.
  int cluster_size = 3;
  int cluster_window = 60;      // nodes
  double cluster_chi2 = 11.34;  // χ²(3 dof) at 99 %
  // A cluster ties older nodes at least this far apart (m): matches against one small
  // place share its ambiguity (a bare corridor's corner fits a scan 2 m off match after
  // match, and such matches agree with each other).
  double cluster_min_spread = 1.0;
  // A closure alone (no cluster) may move its nodes only this far from where the graph has
  // them (a graph uncertain enough bends to fit a wrong closure with χ² near 0); larger
  // corrections need a cluster. Only when cluster_size > 1.
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
  double cluster_verify_window = 30.0;   // m
  double cluster_verify_distance = 4.0;  // m
  double cluster_verify_ratio = 1.0;
  int cluster_verify_nodes = 20;
  // While a closure the check moved is held, attempts search around the pose it gives the
  // robot (its place, then the chain of steps since), not the graph's, which is farther off
  // than the window reaches when the check had to move it.
  bool follow_relocated = true;
  // From single_unique_window on (and at the cap, max_linear_window), a closure goes in
  // alone (a small correction) only when no pose more than single_unique_distance from its
  // match scores single_unique_ratio of it in the window, unless its own covariance spans
  // that pose (sigma_factor σ along the line to it: a bare corridor's axis); otherwise it is
  // held for a cluster. A window of 10-20 m holds a corridor's look-alike. 0: off.
  double single_unique_distance = 1.0;  // m
  double single_unique_ratio = 0.9;
  double single_unique_window = 10.0;  // m
  // A closure's pose from the likelihood field is then refined on the candidate map's
  // points (point-to-line, as tracking) and the refined pose is kept when it moved at most
  // this far; its covariance stays the field's. For a laser precise enough that the field's
  // refinement is the coarser of the two (readFloorSlamOptions: from the laser model). 0: off.
  double point_polish_translation = 0.0;  // m
  double point_polish_rotation = 0.0;     // rad
  // For closures (windows from the options above). They refine on the likelihood field
  // (ScanMatcherOptions::point_refinement false): on the points, closures in a ring corridor
  // landed 1.5-1.9 m wrong (FloorSlam.LoopClosureCorrectsDrift).
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
  std::string known_floor = shipped_slam::relocalization::known_floor;
  GlobalRelocalizationOptions global;
};

struct FloorSlamOptions {
  FloorSlamOptions();
  LaserModel laser;
  ScanMatcherOptions matcher;  // tracking
  NodeCreationOptions node;
  LocalMapOptions local_map;
  OdometryNoiseModel odometry;
  LoopClosureOptions loop_closure;
  RelocalizationOptions relocalization;
  graph::OptimizerOptions optimizer;  // loop closures behind a DCS kernel (δ 5)
  // The tracking window's cap (its floor is the matcher's window; between them 3 σ of the
  // prediction: tracker.h).
  double max_linear_window = 1.5;        // m
  double max_angular_window = M_PI / 2;  // rad: a corridor turned half round fits as well
  // Along a direction where the scan match's information is below degenerate_ratio times
  // the odometry step's (a bare corridor's axis), a new node's position is the two fused
  // by their information, not the match's alone (solution remapping for degenerate
  // directions). 0: the match's position always.
  double degenerate_ratio = 0.1;
  // When the graph is finished (end of input, leaving the floor), each node is also
  // matched against the map of the successor_match_nodes tracked nodes after it, and the
  // match becomes an edge from the next node back to it: the tracking edge measures a step
  // from the scans before it, this one from the scans after it. Both reuse the same scans,
  // so this edge's information is scaled by successor_match_weight. Made at the end, every
  // loop closure is decided on the tracking graph alone. 0: none.
  int successor_match_nodes = 5;
  double successor_match_weight = 0.5;
};

// The options that follow from a laser model: a match's per-point noise floor and its
// covariance floors, the surface normals' tilt, and whether loop closures are polished on
// the map's points.
void applyLaserModel(const LaserModel& laser, FloorSlamOptions* options);

// Reads the front end's keys (all optional; unknown keys are errors): laser.range_noise,
// odometry_noise (translation_per_meter, rotation_per_meter, rotation_per_radian),
// map_resolution, node_spacing (translation, rotation), local_map_nodes, loop_closure
// (true/false), relocalization (known_floor, seed).
FloorSlamOptions readFloorSlamOptions(const common::ConfigNode& node);

}  // namespace storey::mapping
