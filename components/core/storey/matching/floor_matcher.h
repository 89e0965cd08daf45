// Inter-floor constraints by global Monte Carlo localisation: the paper's Algorithm 1
// (Karg et al., ICRA 2010, Sec. IV) with a learned likelihood gate, RANSAC over each
// floor's candidates, a structured choice of the reference floor and provenance for
// every candidate.
//
// Conventions (all poses are Pose2, "a in frame b" means b^-1 * a):
// - A floor graph g_i has its own frame; node n has pose p_n in it. The reference floor
//   g_ref likewise. The *alignment* T_i is the pose of g_i's frame in g_ref's frame, so
//   a node of g_i sits at T_i * p_n in g_ref's frame.
// - The scans z_k .. z_m (m = k + d, node indices in time order) are replayed from
//   uniformly spread particles, moved between nodes by the odometry increments
//   odometry_{n-1}^-1 * odometry_n. When the filter converges at z_m to pose x (in g_ref's
//   frame), x is refined by fitting the scans z_k .. z_m, placed by the graph's poses,
//   to the reference likelihood field; this gives T = x * p_m^-1. The pose of node k
//   at the start of the sequence is back-propagated through the graph's relative poses:
//   x_k = T * p_k (the graph's p_k^-1 * p_m is a better estimate of the motion than raw
//   odometry).
// - q is the reference node nearest x_k. The constraint is the pose of node k of g_i in
//   the frame of node q of g_ref, c = q^-1 * x_k (the paper's c = q p_k^-1 written as a
//   relative pose between the two nodes), plus dz = height(g_i) - height(g_ref). A graph
//   optimiser adds it as an edge from q (reference) to k (floor i). The alignment it
//   implies is q * c * p_k^-1.
// - l_t is the mean over particles of each particle's observation likelihood, where a
//   particle's likelihood is the geometric mean of its beams' p(endpoint) in the
//   likelihood field (so it does not depend on the number of beams). l_min for a pair is
//   likelihood_scale * min(l_min(g_ref), l_min(g_i)), where l_min(g) is the
//   `likelihood_quantile` quantile (default 0.05, the 5th percentile) of l_t while
//   tracking g's own scans in g's own map from its first node's pose (moved by the
//   graph's relative poses, with the filter's motion noise). That map is
//   rendered from g's even-indexed nodes and l_t is taken at the odd-indexed ones, so no
//   scan is scored against a map built from itself (which would make l_min optimistic).
//   l_min(g) is at least half the median of those l_t, so a tracker that drifted for a
//   while in a featureless corridor does not disable the gate.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"
#include "storey/geometry/pose2.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/grid/point_map.h"
#include "storey/localization/particle_filter.h"

namespace storey::matching {

// How far a robot's floor change (lift or stairs: its last node in one graph and its next
// node in another) may take it, as a placement of the two graphs puts it: a lift leaves the
// robot where it entered, a stairwell a few metres on, and its odometry carries the heading
// through (a degree or two of wheel slip when it turns in the cabin).
struct FloorChangeLimits {
  double radius = 0.0;  // m between the two nodes (0: not checked)
  double heading =
      0.0;  // rad between the turn the placement implies and the odometry's (0: not checked)
  bool off() const { return radius <= 0.0 && heading <= 0.0; }
};

// The shipped file's matcher values (config/floor_matcher.yaml, `floor_matcher`), the
// defaults below.
namespace shipped_matcher = shipped::floor_matcher::floor_matcher;
// The particle filter's options with the keys under `filter:` from the shipped file.
localization::ParticleFilterOptions shippedMatcherFilter();

struct FloorMatcherOptions {
  localization::ParticleFilterOptions filter = shippedMatcherFilter();
  grid::OccupancyGridOptions map;                 // rendering each floor graph's map
  grid::LikelihoodFieldOptions likelihood_field;  // its sensor model
  // A sequence z_k..z_m needs at least `min_sequence` scans before convergence counts;
  // a filter not converged after `max_sequence` scans is dropped and restarted
  // `restart_stride` nodes later.
  int min_sequence = shipped_matcher::min_sequence;
  int max_sequence = shipped_matcher::max_sequence;
  int restart_stride = shipped_matcher::restart_stride;
  // Likelihood gate (see the header comment).
  double likelihood_quantile = shipped_matcher::likelihood_quantile;
  // scans of another floor see furniture the reference lacks
  double likelihood_scale = shipped_matcher::likelihood_scale;
  int learning_particles = shipped_matcher::learning_particles;
  // Refinement of each converged estimate against the reference likelihood field.
  int refine_iterations = shipped_matcher::refine_iterations;
  // beams per scan used in refinement
  int refine_beams = shipped_matcher::refine_beams;
  // metres; a larger correction rejects the candidate
  double max_refine_correction = shipped_matcher::max_refine_correction;
  // minimum mean score after refinement, [0, 1]
  double min_fit = shipped_matcher::min_fit;
  // An accepted set's joint alignment is refined last on the reference floor's scan
  // points (point-to-line below the map's cell, grid::alignToPoints) with every scan of
  // the floor (or only the inliers' scans: point_refinement_whole_floor false). The
  // inliers sit where the floors share structure, often one lobby, whose few metres fix
  // the rotation to a few tenths of a degree; the whole floor's scans, where they lie on
  // the reference's walls (0.15 m, robust), fix it over the building's extent.
  // point_cell_size 0 leaves the alignment at the likelihood field's refinement.
  double point_cell_size = shipped_matcher::point_cell_size;
  bool point_refinement_whole_floor = shipped_matcher::point_refinement_whole_floor;
  // The joint alignment of a set with candidates of both directions: g_i's scans fitted in
  // g_ref's map and g_ref's scans fitted in g_i's map, the two combined by their scan
  // counts (false: g_i's scans only, when there are any). A set whose forward scans all
  // lie in an elevator cabin, where a floor graph's headings are the least sure (glass3),
  // then also rests on the corridor scans of the other floor.
  bool joint_alignment_both_directions = shipped_matcher::joint_alignment_both_directions;
  double point_normal_radius = shipped_matcher::point_normal_radius;
  double point_correspondence_distance = shipped_matcher::point_correspondence_distance;
  double point_robust_distance = shipped_matcher::point_robust_distance;
  // Each accepted constraint takes its heading from the joint alignment and, when true,
  // its translation from its own scans' fit on the reference's points (within
  // 2 x point_correspondence_distance of the joint's): the floor graphs are not rigid,
  // and constraints at both ends of a corridor can then correct its length.
  bool local_constraint_translation = shipped_matcher::local_constraint_translation;
  // RANSAC: the model is one planar alignment T_i; candidates agree when their
  // alignments place node k within these tolerances.
  int ransac_iterations = shipped_matcher::ransac_iterations;
  // metres
  double ransac_translation_tolerance = shipped_matcher::ransac_translation_tolerance;
  // rad
  double ransac_rotation_tolerance = shipped_matcher::ransac_rotation_tolerance;
  // Floor graphs are not rigid (a bare corridor's length is off by up to ~1 %): after
  // RANSAC, a candidate outside the largest set also joins it when it agrees with the
  // set's mean alignment within ransac_translation_tolerance plus this fraction of the
  // distance from its node k to the set's nearest node k (so only far from where the set
  // anchors the floor). With this on, every accepted candidate that the joint alignment
  // does not place within the RANSAC tolerance keeps its own measurement, not the joint
  // alignment's, so the building graph learns where that part of the floor lies. Rival sets
  // (ambiguity), the self-check's twins and evidence combined through an aligned floor stay rigid.
  // m per m
  double ransac_distortion = shipped_matcher::ransac_distortion;
  int min_constraints = shipped_matcher::min_constraints;
  // A floor whose second-largest consistent set (disjoint from the largest) has at least
  // max(2, ambiguity_ratio * largest) candidates is ambiguous: no constraint.
  double ambiguity_ratio = shipped_matcher::ambiguity_ratio;
  // ...unless the largest set's alignment makes all of g_i's scans fit the reference map
  // better by this much (mean likelihood-field score, in [0, 1]) than the second's.
  double ambiguity_fit_margin = shipped_matcher::ambiguity_fit_margin;
  // Information of each accepted constraint: 1/sigma_xy^2 along the direction its scans
  // pin best, 1/sigma_theta^2 in heading, and along the weakest direction
  // ratio/sigma_xy^2, where ratio is the weak/strong eigenvalue ratio of its scans'
  // point-to-line information on the map they were localised in (heading marginalised,
  // normal noise discounted by normal_tilt_stddev): a sequence down a bare corridor says
  // little about where along the corridor it is, and its constraint says so too.
  double constraint_sigma_xy = shipped_matcher::constraint_sigma_xy;
  double constraint_sigma_theta = shipped_matcher::constraint_sigma_theta;
  // rad; see mapping::ScanMatcherOptions
  double normal_tilt_stddev = shipped_matcher::normal_tilt_stddev;
  // A candidate whose weakest direction's sigma (constraint_sigma_xy / sqrt(ratio)) is
  // larger is not evidence (status underconstrained): it cannot tell places this far apart
  // along it. 0 turns the gate off. Needs point_cell_size > 0 (else no ratio is computed).
  double max_weak_sigma = shipped_matcher::max_weak_sigma;
  // Self-similarity check: every floor's own scans are matched against its own map. A
  // floor where a consistent set of them localises at another alignment, at least
  // max(2, ambiguity_ratio * the set at the identity), is symmetric or periodic: it is
  // never a reference and never gets a constraint, unless the identity fits all of the
  // floor's scans better by ambiguity_fit_margin than that other alignment does, or at
  // least max(2, ambiguity_ratio * that set) of its sequences at the identity fit worse
  // by that margin when placed by the other alignment (FloorCheck::refuted).
  bool self_check = shipped_matcher::self_check;
  // A self-similar floor is matched anyway, through its sequences that tell it from its
  // twin: a candidate of a pair where either floor is self-similar counts only if its
  // scans fit the other floor's map worse by ambiguity_fit_margin at each twin of its
  // alignment (the reference's twin composed on the left, the floor's own on the right)
  // than at the alignment itself. Self-similar floors come last as references. Off: such
  // floors get no constraint at all.
  bool match_self_similar = shipped_matcher::match_self_similar;
  // When a pair is not accepted (too few consistent candidates, or two rival sets), g_ref's
  // scans are also localised in g_i's map and those candidates, inverted, join the same
  // RANSAC: structure g_i's robot passed only briefly may be where g_ref's robot stayed.
  bool match_both_directions = shipped_matcher::match_both_directions;
  // ...and both floors' scans are also replayed last to first (time-reversed sequences).
  // Candidates whose scans overlap count once in RANSAC (see largestConsistentSet).
  bool backwards_sequences = shipped_matcher::backwards_sequences;
  // Negative information: a gated candidate whose beams cross solid walls of the reference
  // (Candidate::see_through) more than this fraction is localised again from its first
  // scan with the wall model in the filter (WallModel: `wall_beams` traced per scan, a beam
  // through a wall has log p `wall_log_p`). 1 turns it off.
  double wall_recheck = shipped_matcher::wall_recheck;
  int wall_beams = shipped_matcher::wall_beams;
  // rechecks per pair; past it, such candidates are dropped
  int wall_recheck_max = shipped_matcher::wall_recheck_max;
  double wall_log_p = shipped_matcher::wall_log_p;
  // Two graphs of one floor id see the same walls: a pair's accepted alignment is
  // rejected (kContradicted) when more than this fraction of each graph's scans see
  // through the other's solid walls, a scan seeing through when `same_floor_through_beams`
  // of its beams (refine_beams traced) cross one 0.3 m or more before their endpoint. A
  // periodic row of rooms fits a young graph several rooms along, but there each graph's
  // scans down the corridor see through the other's end walls. Both ways: at the right
  // alignment one graph's scans may see through the other's walls where the two saw the
  // floor differently (a door open for one robot and shut for the other can leave about a
  // tenth of one graph's scans seeing through, none the other way). 1 turns it off.
  double same_floor_see_through = shipped_matcher::same_floor_see_through;
  int same_floor_through_beams = shipped_matcher::same_floor_through_beams;
  // A pair's accepted alignment that puts a robot's floor change, to a graph already placed,
  // outside these limits is rejected (kContradicted) and the graph tries the others: a floor
  // that shares only a lift with another can fit a look-alike of it turned about the lift,
  // which turns the robot's ride against its odometry. A growth pass
  // (GrowthPassConfirmation) holds back what it places outside them, too. A journal whose
  // nodes carry no raw odometry (odom_x/y/theta all zero) needs the heading check off (0).
  FloorChangeLimits floor_change{shipped_matcher::floor_change_radius,
                                 shipped_matcher::floor_change_heading};
  int threads = shipped_matcher::threads;
  std::uint64_t seed = shipped_matcher::seed;
};
FloorMatcherOptions readFloorMatcherOptions(const common::ConfigNode& node);

enum class CandidateStatus {
  kAccepted,          // RANSAC inlier of an accepted floor
  kLowLikelihood,     // l_t < l_min
  kPoorFit,           // refinement moved too far or fit too low
  kOutlier,           // not in the largest consistent set
  kTooFew,            // the largest consistent set is below min_constraints
  kAmbiguous,         // two disjoint consistent sets (symmetric floor)
  kUnderconstrained,  // its scans do not pin one direction (max_weak_sigma)
  kContradicted,      // its set places two graphs of one floor so that one sees through the
                      // other's walls (same_floor_see_through), or it or its set places a
                      // robot's floor change at odds with its odometry (floor_change)
};
const char* candidateStatusName(CandidateStatus status);

// One hypothesis from a converged filter, with its provenance.
struct Candidate {
  int reference_graph_id = 0;
  int graph_id = 0;
  // Node indices of the sequence z_k .. z_m: into g_i's nodes, or into g_ref's nodes when
  // `reversed` (g_ref's scans were localised in g_i's map; the alignment and the
  // measurement are then inverted so they read as for a forward candidate).
  int first_index = 0;
  int last_index = 0;
  bool reversed = false;
  bool backwards = false;       // the scans were replayed last to first (k is then the later)
  int node_index = 0;           // index into g_i's nodes of node_id
  int node_id = 0;              // id of node k in g_i (reversed: g_i's node nearest g_ref's k)
  int reference_node_id = 0;    // id of node q in g_ref (reversed: g_ref's node k)
  geometry::Pose2 estimate;     // MCL mean at z_m, g_ref frame (before refinement)
  geometry::Pose2 alignment;    // T_i implied by this candidate (refined)
  geometry::Pose2 measurement;  // node k in the frame of node q (accepted: from the joint
                                // alignment of all inliers, q the reference node nearest)
  double dz = 0.0;
  double likelihood = 0.0;  // l_t at convergence
  double l_min = 0.0;
  double fit = 0.0;                // mean likelihood-field score of the sequence after refinement
  double refine_correction = 0.0;  // metres the refinement moved node m
  // Fraction of the sequence's beams that, placed by `alignment`, cross a solid wall of the
  // map they were localised in (solidWalls) before their endpoint.
  double see_through = -1.0;  // -1: not computed (only pairs that need more evidence)
  // Conditioning of its scans' point-to-line information on the map they were localised
  // in (grid::translationConditioning after the normal-noise discount): the weak/strong
  // ratio (-1: not computed) and the weak direction, an angle in that map's frame (after
  // acceptance: in the frame of the reference node of `measurement`).
  double information_ratio = -1.0;
  double weak_direction = 0.0;
  std::size_t particles = 0;  // filter size at convergence
  double mass_within = 0.0;
  // A self-similar floor's twin alignment fits its scans about as well (then kAmbiguous
  // for good: a pair's second pass does not test it again).
  bool fits_twin = false;
  CandidateStatus status = CandidateStatus::kOutlier;
  std::string reason;
};

struct InterFloorConstraint {
  int reference_graph_id = 0;
  int reference_node_id = 0;
  int graph_id = 0;
  int node_id = 0;
  geometry::Pose2 measurement;  // node in the frame of the reference node
  double dz = 0.0;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  double likelihood = 0.0;
  int first_index = 0, last_index = 0;
};

// Matching one floor graph against one reference.
struct PairResult {
  int reference_graph_id = 0;
  int graph_id = 0;
  bool accepted = false;
  bool ambiguous = false;  // two disjoint consistent sets: the floor's structure repeats
  std::vector<geometry::Pose2> set_alignments;  // when ambiguous: each set's alignment
  // Its set placed two graphs of one floor where they see through each other's walls
  // (same_floor_see_through): the graph tries no other this pass. Also set on a pair
  // withdrawn by rejectContradictedPlacements.
  bool contradicted = false;
  std::string reason;                           // why not accepted (or "accepted")
  geometry::Pose2 alignment;                    // T_i from all inliers jointly (when accepted)
  double l_min = 0.0;
  int sequences = 0;            // filters started
  int not_converged = 0;        // filters dropped without converging
  int reversed_candidates = 0;  // candidates from g_ref's scans in g_i's map (both directions)
  int wall_rechecks = 0;        // candidates re-localised with the wall model
  std::vector<Candidate> candidates;
  std::uint64_t beam_evaluations = 0;
  double seconds = 0.0;
};

// What the self-similarity check found for one floor graph.
struct FloorCheck {
  int graph_id = 0;
  std::size_t structure = 0;
  double l_min = 0.0;
  int at_identity = 0;  // own candidates consistent with the identity
  int elsewhere = 0;    // largest consistent set of own candidates at another alignment
  // When that set is large enough: whole-floor fit at the identity and at its alignment
  // (-1 when not computed). Self-similar only if the identity is not clearly better.
  double fit_identity = -1.0;
  double fit_elsewhere = -1.0;
  geometry::Pose2 other;  // that set's (refined) alignment of the floor onto itself
  // Own sequences at the identity whose scans, placed by `other`, fit the floor's map
  // worse by more than ambiguity_fit_margin: places the twin does not explain.
  int refuted = 0;
  bool self_similar = false;
};

struct MatchResult {
  int reference_graph_id = -1;
  std::vector<FloorCheck> floors;
  std::vector<PairResult> pairs;
  std::vector<InterFloorConstraint> constraints;  // every accepted candidate
  std::uint64_t beam_evaluations = 0;
  double seconds = 0.0;
  const PairResult* pairFor(int graph_id) const;  // the accepted pair, else the last tried
};

// A floor graph made ready for matching: its map, likelihood field, free space, l_min.
struct PreparedFloor {
  const floor::FloorGraph* graph = nullptr;
  std::unique_ptr<localization::LocalizationMap> map;
  double l_min = 0.0;         // learned quantile (before likelihood_scale)
  std::size_t structure = 0;  // occupied cells: how much there is to localise against
  grid::PointMap points;      // its scans' returns per cell (empty: point_cell_size 0)
  // A self-similar floor's other alignment onto itself (FloorCheck::other), when it is
  // matched anyway (FloorMatcherOptions::match_self_similar).
  std::optional<geometry::Pose2> twin;
  // solidWalls() of the map and its WallModel, computed on first use (only pairs that
  // need more evidence use them); safe to call from several threads.
  const std::vector<std::uint8_t>& walls(const FloorMatcherOptions& options) const;
  const localization::WallModel& wallModel(const FloorMatcherOptions& options) const;

 private:
  struct Walls {
    std::once_flag once;
    std::vector<std::uint8_t> cells;
    localization::WallModel model;
  };
  void computeWalls(const FloorMatcherOptions& options) const;
  std::shared_ptr<Walls> walls_ = std::make_shared<Walls>();
};
PreparedFloor prepareFloor(const floor::FloorGraph& graph, const FloorMatcherOptions& options);

// l_min(g): tracks g's scans in g's own map (held out as above); the quantile of l_t.
double learnLikelihoodThreshold(const floor::FloorGraph& graph, const FloorMatcherOptions& options,
                                std::uint64_t seed);

// Why a candidate's alignment (g_i's frame into g_ref's) is refuted before RANSAC ("" when
// it is not): matchFloors checks it against the robots' floor changes.
using AlignmentCheck = std::function<std::string(const geometry::Pose2& alignment)>;

// Algorithm 1 for one pair: candidates, gate, refinement, RANSAC; when that does not
// accept and options.match_both_directions, g_ref's scans localised in g_i's map join in.
// Candidates that `refuted` refutes take no part in RANSAC (kContradicted).
PairResult matchPair(const PreparedFloor& reference, const PreparedFloor& floor,
                     const FloorMatcherOptions& options, std::uint64_t seed,
                     const AlignmentCheck& refuted = {});

// RANSAC over one directed pair's candidates that passed the gate (status kOutlier on
// entry), rival sets, and the accepted set's joint alignment and constraints: each
// candidate's final status, and the measurement of each accepted one. matchPair calls
// it; declared here for tests.
void decideConsistentSet(const PreparedFloor& reference, const PreparedFloor& floor,
                         const FloorMatcherOptions& options, std::mt19937_64* rng,
                         PairResult* result);

// `alignment` (scans_graph's frame into map_floor's) refined on scans_graph's scans
// `ranges` in map_floor's map: on the likelihood field, then on the map's points, with
// the whole floor's scans where most of them lie on its walls (floors that share their
// layout; point_refinement_whole_floor), else with the ranges' own. The field's
// refinement of a few metres of scans can be off by half a degree, which the points
// resolve (glass3: floors that share only a lift and its lobby). Declared for tests.
geometry::Pose2 refinedOnScans(const PreparedFloor& map_floor, const floor::FloorGraph& scans_graph,
                               const std::vector<std::pair<int, int>>& ranges,
                               const FloorMatcherOptions& options, geometry::Pose2 alignment);

// Evidence through an aligned graph: g_i (`floor`) failed against the reference for too
// few consistent candidates (`direct`) and again against g_r (`aligned`), whose accepted
// alignment into the reference's frame is `t_r` (`via`). One RANSAC over both pairs'
// candidates, g_r's mapped through t_r; accepted with min_constraints disjoint candidates
// and no standing rival set (the whole floor fitted in both maps decides, as in a pair),
// then the joint alignment is refined on every inlier's scans in the map it was localised
// in. matchFloors calls it; declared here for tests.
PairResult combineThroughAligned(const PairResult& direct, const PairResult& via,
                                 const geometry::Pose2& t_r, const PreparedFloor& reference,
                                 const PreparedFloor& aligned, const PreparedFloor& floor,
                                 const FloorMatcherOptions& options, std::uint64_t seed);

// The self-similarity check of one floor (see FloorMatcherOptions::self_check).
FloorCheck checkSelfSimilarity(const PreparedFloor& floor, const FloorMatcherOptions& options,
                               std::uint64_t seed);

// Two alignments of one floor, weighted (by the scans that fitted each): translation by
// the weighted mean, heading by the weighted circular mean. Two alignments that agree
// where the scans lie differ in translation by their heading difference times the lever
// arm from the floor's origin; the weighted means keep that place to first order.
geometry::Pose2 combineAlignments(const geometry::Pose2& a, double weight_a, const geometry::Pose2& b,
                                  double weight_b);

// The information of an accepted candidate's constraint over (dx, dy, dθ) in the frame of
// its reference node (see FloorMatcherOptions::constraint_sigma_xy).
Eigen::Matrix3d constraintInformation(const Candidate& c, const FloorMatcherOptions& options);

// All floor graphs: the reference is the graph with most structure among those not
// self-similar; every other graph is matched to it in parallel. A graph that fails for
// too few consistent candidates tries the others (same floor id first, then by
// structure) until one accepts; one found ambiguous tries only graphs already aligned
// to the reference (its own floor id first), and such a retry must agree, through the
// reference, with one of its two sets; one whose pair is contradicted tries none. Every
// pair's candidates, and its accepted alignment, are checked against the robots' floor
// changes to graphs already placed (floorChangeContradiction; refuted candidates take no
// part in RANSAC). Last, graphs of one floor placed through others are checked against
// each other (rejectContradictedPlacements).
MatchResult matchFloors(const std::vector<floor::FloorGraph>& graphs,
                        const FloorMatcherOptions& options);

// The candidates of `pool` outside the rigid set `core` (a RANSAC set: every candidate
// agreeing with its hypothesis) that agree with the core's mean alignment within
// ransac_translation_tolerance plus ransac_distortion x the distance from their node k to
// the nearest core candidate's node k (graph = the graph their node k belongs to). A floor
// graph bent between where the core anchors it and where they lie (a bare corridor 0.8 %
// short) puts right candidates that far off the rigid model, while a candidate beside the
// core gets no allowance.
std::vector<std::size_t> bentFloorCandidates(const std::vector<Candidate>& cands,
                                             const std::vector<std::size_t>& pool,
                                             const std::vector<std::size_t>& core,
                                             const floor::FloorGraph& graph, const FloorMatcherOptions& o);

// Refines an alignment T (g_i frame in g_ref frame) so the scans of the node index
// ranges [first, last], placed at T * pose, fit the field (Gauss-Newton on 1 - score).
// Returns the mean score in [0, 1].
double refineAlignment(const grid::LikelihoodField& field, const floor::FloorGraph& graph,
                       const std::vector<std::pair<int, int>>& ranges, int beams, int iterations,
                       geometry::Pose2* alignment);

// The cells of `field`'s map that are walls its own floor's scans never passed through
// (1) over the field's frame: occupied cells, less those a beam of `graph` crossed (a
// landing door seen open, a passer-by). Up to `beams` beams per scan are traced.
std::vector<std::uint8_t> solidWalls(const grid::LikelihoodField& field,
                                     const floor::FloorGraph& graph, int beams);

// Fraction of the beams of the scans in `ranges` (up to `beams` per scan, placed at
// alignment * pose) whose ray crosses a cell of `walls` (over frame `f`) more than
// `margin` metres before its endpoint: a laser does not see through walls.
double seeThroughFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                          const floor::FloorGraph& graph,
                          const std::vector<std::pair<int, int>>& ranges, int beams,
                          const geometry::Pose2& alignment, double margin);

// Two graphs of one floor id see the same walls (FloorMatcherOptions::same_floor_see_through):
// empty unless `alignment` (floor's frame in reference's) lets more than
// same_floor_see_through of each graph's scans see through the other's solid walls, else
// what contradicts it. Graphs of different floor ids, or a graph with itself, are never
// contradicted.
std::string sameFloorContradiction(const PreparedFloor& reference, const PreparedFloor& floor,
                                   const geometry::Pose2& alignment,
                                   const FloorMatcherOptions& options);

// How a placement puts one robot's floor change `link`, its nodes `from` and `to` placed
// by `from_frame` and `to_frame`: "" when it keeps within `limits`, else "puts the floor change
// from graph A (node a) to graph B (node b) D m apart" or "... turned N deg from the robot's
// odometry". The matcher's floor-change check and a growth pass's confirmation (retraction.h) both
// judge by it.
std::string floorChangeAtOdds(const floor::TransitLink& link, const floor::FloorNode& from,
                              const geometry::Pose2& from_frame, const floor::FloorNode& to,
                              const geometry::Pose2& to_frame, const FloorChangeLimits& limits);

// Why placing graph `graph_id` at `placed` (its frame into the reference's) contradicts
// one of `links` (floor::transitLinks of `graphs`) to or from a graph in `placed_graphs`
// (graph id -> its frame in the reference's): "" when none does
// (FloorMatcherOptions::floor_change). matchFloors calls it
// for every accepted pair; declared here for tests.
std::string floorChangeContradiction(const std::vector<floor::FloorGraph>& graphs,
                                     const std::vector<floor::TransitLink>& links, int graph_id,
                                     const geometry::Pose2& placed,
                                     const std::map<int, geometry::Pose2>& placed_graphs,
                                     const FloorMatcherOptions& options);

// After a pass: two graphs of one floor id that it placed only through other graphs (each
// aligned to a third) and whose implied placement sameFloorContradiction rejects. Both
// graphs' accepted pairs, and pairs taking either as their reference, are withdrawn
// (accepted false, contradicted, candidates kContradicted); result->constraints is left for
// the caller to rebuild. `prepared` is in `graphs`' order. Returns whether any pair was
// withdrawn. matchFloors calls it; declared here for tests.
bool rejectContradictedPlacements(const std::vector<floor::FloorGraph>& graphs,
                                  const std::vector<PreparedFloor>& prepared,
                                  const FloorMatcherOptions& options, MatchResult* result);

// Fraction of `graph`'s scans (up to `beams` traced each, placed at alignment * pose) of
// which at least `min_beams` beams cross a cell of `walls` (over frame `f`) 0.3 m or more
// before their endpoint.
double seeThroughScanFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                              const floor::FloorGraph& graph, int beams,
                              const geometry::Pose2& alignment, int min_beams);

// The candidate-by-candidate provenance table.
void printMatchReport(std::ostream& out, const MatchResult& result);

}  // namespace storey::matching
