// Helpers the floor matcher's stages share (consistent_set.cpp, alignment_refinement.cpp,
// wall_evidence.cpp, sequence_localisation.cpp, pair_matching.cpp, floor_matcher.cpp):
// internal to storey::matching, not part of its interface.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/grid/point_map.h"
#include "storey/matching/floor_matcher.h"

namespace storey::matching {

// The names every stage of the matcher uses (this header is included by the stages only).
using geometry::normalizeAngle;
using geometry::Pose2;
using localization::FilterState;
using localization::LocalizationMap;
using localization::makeWallModel;
using localization::ParticleFilter;
using localization::readParticleFilterOptions;
using localization::selectBeams;
using localization::WallModel;

}  // namespace storey::matching

namespace storey::matching::detail {

using geometry::Pose2;

// Metres before its endpoint a beam may cross a wall: it may end just past the wall it hit.
constexpr double kWallMargin = 0.3;

// An accepted pair taken back: not accepted, and its accepted candidates kContradicted.
void takeBack(const std::string& candidate_reason, PairResult* p);

// An accepted pair whose placement two graphs of one floor contradict: taken back, and
// the graph tries no other this pass (sameFloorContradiction).
void withdrawAsContradicted(const std::string& pair_reason, const std::string& candidate_reason,
                            PairResult* p);

// Deterministic per-job seeds, independent of thread scheduling.
std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t a, std::uint64_t b);

// Whether a candidate got past the likelihood gate, the refinement and the conditioning
// gate (RANSAC decides the rest).
bool passedGate(CandidateStatus s);

// A candidate's scans as one node range in graph order, for refineAlignment (a backwards
// sequence's first index is its later node).
std::vector<std::pair<int, int>> orderedRange(const Candidate& c);

double quantile(std::vector<double> values, double q);

// Does alignment `a` place node `node_pose` where alignment `b` does?
bool agrees(const Pose2& a, const Pose2& b, const Pose2& node_pose, double tol_t, double tol_r);

// Mean of alignments: translation averaged, heading by circular mean; each weighted by
// `weights` when given (else alike).
Pose2 meanAlignment(const std::vector<Pose2>& poses, const std::vector<double>& weights = {});

// Scans in a set of node ranges [first, last].
int scanCount(const std::vector<std::pair<int, int>>& ranges);

// The candidates of `set` whose scans are pairwise disjoint, as many as possible (per
// source graph, earliest-ending first): a time-reversed sequence and a forward one over
// the same scans are one piece of evidence, not two. Two sequences that share only their
// end scan count as two (the paper's own sequences do: k <- k + d), so a forward pass
// ending where a time-reversed one ends is not lost; but not when that scan is node k
// of both, which would give the same constraint twice.
std::vector<std::size_t> disjointSubset(const std::vector<Candidate>& cands,
                                        std::vector<std::size_t> set);

// Largest set of candidates (among `pool`) agreeing with one candidate's alignment,
// counting candidates with overlapping scans once (the set returned is disjoint; `all`,
// when given, receives every candidate agreeing with the winning hypothesis).
std::vector<std::size_t> largestConsistentSet(const std::vector<Candidate>& cands,
                                              const std::vector<std::size_t>& pool,
                                              const floor::FloorGraph& graph,
                                              const FloorMatcherOptions& o, std::mt19937_64* rng,
                                              std::vector<std::size_t>* all = nullptr);

// The fit of *all* of `scans_graph`'s scans in map_floor's map, `alignment` (their
// frame into map_floor's) refined from where it is, on a third of the refinement's beams:
// how rival alignments (and a floor's twin) are told apart.
double wholeFloorFit(const PreparedFloor& map_floor, const floor::FloorGraph& scans_graph,
                     const FloorMatcherOptions& o, Pose2* alignment);

// Whether a second consistent set makes a pair ambiguous. A rival by count (at least
// ambiguity_ratio of the largest set, and 2 or more) stands unless the whole floor fits
// the largest set's alignment better by ambiguity_fit_margin; a smaller second set large
// enough to be accepted alone stands when the whole floor fits it better (along a
// periodic row of rooms more sequences may agree on a place a few rooms off than at the
// true one). `fits()` returns the whole floor's fit at the two sets' alignments; it is
// only called for a rival.
bool secondSetStands(std::size_t best, std::size_t second, const FloorMatcherOptions& o,
                     const std::function<std::pair<double, double>()>& fits);

// The translation of `joint` that best fits one candidate's own scans (nodes first..last)
// on the reference's points, the heading held at the joint's. A floor graph is not rigid
// (a bare corridor's length is off by a few tenths of a per cent): where this candidate's
// scans lie, the floor may sit a little off the joint alignment, and a constraint that
// says so lets the building graph take up the distortion. Returns `joint` when the fit
// moves further than the points' correspondence reach or rests on too few points.
Pose2 localTranslation(const grid::PointMap& map, const floor::FloorGraph& graph, int first,
                       int last, const Pose2& joint, const FloorMatcherOptions& o);

// A gated candidate whose beams cross solid walls of the map it was localised in more than
// o.wall_recheck: the likelihood field scores only where beams end, so it may have
// preferred a wrong place (a corridor seen from inside fits both ways round when its open
// end shows rooms the reference lacks). The same scans again from z_k, with the wall model
// in the filter; the candidate is replaced by what that filter finds, or rejected when it
// does not converge. Returns the last replay position used.
int recheckWalls(const PreparedFloor& map_floor, const PreparedFloor& scans_floor, double l_min,
                 const FloorMatcherOptions& o, std::uint64_t seed, Candidate* c,
                 PairResult* counters, std::uint64_t* evaluations);

// Algorithm 1's loop: replays `scans`' node scans in `map`'s map from uniform particles,
// one sequence after another, and turns each converged filter into a candidate whose
// alignment is `scans`' frame in `map`'s frame (the caller re-expresses it when the
// direction is reversed). Gated against `l_min`. With `backwards`, the scans are replayed
// last to first (the odometry increments inverted): a sequence then starts where the
// robot ended, so a pass through shared structure at the end of a visit is seen from
// its far end first, as the pass at the start of a visit is forwards. With `walls`, each
// gated candidate goes through recheckWalls.
std::vector<Candidate> localiseSequences(const PreparedFloor& map_floor,
                                         const PreparedFloor& scans_floor, double l_min,
                                         const FloorMatcherOptions& o, std::uint64_t seed,
                                         bool backwards, bool walls, PairResult* counters,
                                         std::uint64_t* evaluations);

// A candidate found by localising g_ref's scans in g_i's map, re-expressed as evidence
// about g_i in g_ref: the alignment is inverted, and the constraint between node k of
// g_ref and the nearest node q of g_i is written from g_ref's node to g_i's node.
Candidate reverseCandidate(const Candidate& r, const floor::FloorGraph& ref,
                           const floor::FloorGraph& g);

// An accepted candidate's weak direction, from the frame of the map its scans were
// localised in (the other graph's; g_i's when reversed, then turned by the alignment of
// g_i in the other graph) to the frame of node q of its measurement.
double weakDirectionAt(const Candidate& c, const Pose2& alignment, const Pose2& q);

}  // namespace storey::matching::detail
