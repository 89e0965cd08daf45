// Which published inter-floor constraints a new matching pass no longer stands behind.
//
// A live matcher matches again whenever floor graphs have grown; each pass sees more of
// every floor and can overturn what an earlier pass accepted on less (a periodic row of
// rooms that looked unique until the robot saw its neighbour). The pass's accepted
// constraints place the graphs relative to each other; a constraint published earlier is
// retracted when the new pass places its two graphs differently by more than a tolerance,
// or when the new pass finds one of its graphs ambiguous (two consistent sets, or a
// self-similar floor) and aligns it nowhere. A graph the new pass merely fails to align
// (too few candidates) keeps its constraints: absence of evidence does not refute them.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"
#include "storey/matching/floor_matcher.h"

namespace storey::matching {

struct RetractionOptions {
  bool enabled = shipped::floor_matcher::retraction::enabled;
  // How far the new pass may place a published constraint's node from where the
  // constraint put it before that constraint is retracted, and how closely an earlier pass
  // must agree to confirm one: the translation by which the scenarios judge a constraint
  // wrong (0.3 m), half their rotation (1 deg of 2): with the judge's own 2 deg a pass
  // that placed a pair 1.9 deg from a constraint 2.01 deg off confirmed it and never
  // withdrew it (docs/decisions/0005-growth-pass-confirmation.md).
  // m
  double translation = shipped::floor_matcher::retraction::translation;
  // rad
  double rotation = shipped::floor_matcher::retraction::rotation;
  // Along a constraint's weak direction (a corridor's length) the limit is this many of
  // the sigmas its information claims, if that is more: the wrong-constraint judge's rule
  // (constraint_judgement.h). A fixed limit withdrew right corridor constraints whose
  // node a later pass placed 0.35-0.48 m further along the corridor.
  double weak_sigmas = shipped::floor_matcher::retraction::weak_sigmas;
  // A pass on growing graphs publishes a constraint only when an earlier pass placed its
  // two graphs the same way and one of them has grown by this fraction since then. A pass
  // that saw the same two graphs again (a third graph's growth triggered it) is no more
  // evidence: its filters see the same scans in the same map.
  double confirm_growth = shipped::floor_matcher::retraction::confirm_growth;
  // ...and only when the pass's accepted candidates for the pair include scans of each
  // graph localised in the other's map. A young graph's small map lets another floor's
  // scans fit a local look-alike (a corridor's dead end at a lift) while its own scans,
  // in the other's whole map, do not agree.
  bool confirm_both_sides = shipped::floor_matcher::retraction::confirm_both_sides;
};
RetractionOptions readRetractionOptions(const common::ConfigNode& node);

// A pass's placement of the graphs its constraints connect: each in the frame of one graph
// of its connected set (`component` names that graph).
struct GraphPlacement {
  std::map<int, geometry::Pose2> frame;
  std::map<int, int> component;
  bool joins(int a, int b) const;  // both placed, in one connected set
};
// An accepted pair's constraints share its joint alignment, so one per pair places it.
GraphPlacement placeGraphs(const std::vector<floor::FloorGraph>& graphs, const MatchResult& result);
// Whether `placement` puts constraint `c`'s node (current poses in `graphs`) where `c`
// does, judged in the reference node's frame by what `c`'s information claims (the
// wrong-constraint judge with the options as its limits): 0 within them, 1 beyond them
// (`why` says how far), -1 when it cannot tell (a graph not placed or not joined to the
// other, or a node `graphs` lack).
int placementDisagreement(const InterFloorConstraint& c, const std::vector<floor::FloorGraph>& graphs,
                          const GraphPlacement& placement, const RetractionOptions& options,
                          std::string* why = nullptr);

// The placements of the passes so far, each with the size of every graph it matched, so
// that a later pass's constraint is confirmed against a pass that saw less of its graphs.
class PlacementHistory {
 public:
  void record(const std::vector<floor::FloorGraph>& graphs, const MatchResult& result);
  // Whether an earlier pass confirms `c` (current poses in `graphs`): the latest recorded
  // pass that joined c's two graphs while one of them had at most 1 / (1 + confirm_growth)
  // of its current nodes places them within the options' limits. (Either graph: a young
  // graph that stays the same size but matches the same place in a grown reference has
  // passed a harder test; and a finished floor's graph never grows.)
  bool confirms(const InterFloorConstraint& c, const std::vector<floor::FloorGraph>& graphs,
                const RetractionOptions& options) const;

 private:
  struct Pass {
    GraphPlacement placement;
    std::map<int, std::size_t> nodes;  // graph id -> nodes the pass matched
  };
  std::vector<Pass> passes_;
};

// Whether the pass's accepted candidates for c's pair include both directions: c's graph's
// scans in its reference's map and the reference's scans in c's graph's map.
bool pairSeenFromBothSides(const InterFloorConstraint& c, const MatchResult& result);

// What a pass on growing graphs may publish: a constraint that `history` confirms,
// (confirm_both_sides) whose pair the pass saw from both sides, and whose graphs the pass
// places keeping every robot's floor change between them within `floor_change` (the
// matcher's limits, FloorMatcherOptions::floor_change: one setting for both checks). A
// young graph that fits a look-alike corridor end 50 m away, or a floor turned about its
// lift, does not.
class GrowthPassConfirmation {
 public:
  GrowthPassConfirmation(const std::vector<floor::FloorGraph>& graphs, const MatchResult& result,
                         const PlacementHistory& history, const RetractionOptions& options,
                         const FloorChangeLimits& floor_change);
  bool confirms(const InterFloorConstraint& c) const;
  // Whether the pass may withdraw published constraint `c`: not when it places c's
  // graphs at odds with a robot's floor change (a pass that turns a floor about its lift
  // is no judge of where the floor lies).
  bool mayRetract(const InterFloorConstraint& c) const;
  // Graphs the pass places at odds with a transit link, with why.
  const std::map<int, std::string>& atOddsWithTransits() const { return at_odds_; }

 private:
  const std::vector<floor::FloorGraph>& graphs_;
  const MatchResult& result_;
  const PlacementHistory& history_;
  RetractionOptions options_;
  std::map<int, std::string> at_odds_;

  bool placedAtOdds(const InterFloorConstraint& c) const;  // either of c's graphs
};

struct Retraction {
  std::size_t index = 0;  // into the published constraints
  std::string reason;
};

// `published`: constraints accepted by earlier passes and not retracted; `graphs`: the
// floor graphs the new pass matched (current node poses); `result`: that pass; `growth`:
// when the pass is a growth pass, its confirmation, and only what it may retract
// (mayRetract) is. Returns the published constraints to retract, in order, each with why.
std::vector<Retraction> constraintsToRetract(const std::vector<InterFloorConstraint>& published,
                                             const std::vector<floor::FloorGraph>& graphs,
                                             const MatchResult& result,
                                             const RetractionOptions& options,
                                             const GrowthPassConfirmation* growth = nullptr);

}  // namespace storey::matching
