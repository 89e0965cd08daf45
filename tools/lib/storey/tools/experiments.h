// The paper's experiments (Karg et al. 2010, Sec. VI-D and VI-E) as one job, behind
// `storey experiments`: the main job (runMapJob) on a simulated building over several
// seeds, each run evaluated against ground truth with and without inter-floor
// constraints, and the figures summarised per floor and per corridor.
//   tower10     x 9 seeds: per-floor alignment error (Fig. 9); goal: every floor within
//               0.05 m / 0.2 deg.
//   featureless x 10 seeds: floor B's corridor length error (Fig. 10; paper: 14.2 % without,
//               5.8 % with); goal: below 1 %.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/eval/metrics.h"
#include "storey/eval/trajectory.h"
#include "storey/matching/constraint_judgement.h"
#include "storey/sensor/laser_scan.h"

namespace storey::tools {

struct ExperimentSpec {
  std::string name;      // "tower10"
  std::string building;  // scenario file name in config/buildings/
  int default_seeds = 1;
  bool floor_goal = false;                // judge every floor against the alignment goal
  std::vector<std::string> goal_corridors;  // corridors judged against the length goal
  std::string paper;                      // what the paper reports, for the table
};

// tower10 and featureless, as above.
const std::vector<ExperimentSpec>& paperExperiments();

struct ExperimentGoals {
  double floor_translation = 0.05;          // m
  double floor_rotation = 0.2 * M_PI / 180;  // rad
  double corridor_error = 0.01;             // |estimated / true - 1|
  // When a constraint, put at one end's true pose, places the other end wrongly for what
  // its information claims (as in the matcher's scenarios; matching::judgeConstraint).
  matching::WrongConstraintLimits wrong;
};

struct ExperimentOptions {
  // A name of paperExperiments(), "all", or the name of any other building in
  // <config>/buildings/ (3 seeds by default, every floor judged against the goal).
  std::string experiment = "all";
  int seeds = 0;                   // 0: each experiment's default (9, 10)
  std::uint64_t first_seed = 1;    // seeds first_seed .. first_seed + seeds - 1
  std::string output_dir = "out/experiments";  // <dir>/<experiment>/seed_<n>/ per run
  std::string config_dir;                      // "" -> the shipped config/
  int domain_id = -1;  // runs of worker k use domain_id + k (-1: ROS_DOMAIN_ID, else 0)
  int jobs = 1;        // runs at the same time, each its own DDS pipeline and domain
  bool without_barometer = false;  // the robots carry no barometer (floor changes from the IMU)
  ExperimentGoals goals;
  // Called after each run (from the worker's thread, serialised): progress.
  std::function<void(const std::string& line)> progress;
};

// One inter-floor constraint checked against ground truth.
struct ConstraintCheck {
  int id = 0;
  std::string floor_from, floor_to;  // true floors of its two nodes
  bool checked = false;              // false when a node has no ground-truth pose
  // node_to as the constraint places it in node_from's frame against the truth, and
  // whether that is wrong for what it claims (all zero and false when not checked).
  matching::ConstraintJudgement judgement;
  // True building-frame positions of its two nodes (where it is, for analysis).
  double from_x = 0.0, from_y = 0.0, to_x = 0.0, to_y = 0.0;
};

// Checks every inter-floor constraint of `graph` against the true poses of its two nodes
// (matched by robot and stamp within `stamp_tolerance`).
std::vector<ConstraintCheck> checkConstraints(const building::BuildingGraph& graph,
                                              const std::vector<eval::PoseRow>& truth,
                                              const ExperimentGoals& goals,
                                              double stamp_tolerance = 1e-3);

// The paper's baseline, "without inter-floor constraints": the same floor graphs joined
// only by the robot's wheel odometry from its last node on one floor graph to its first
// node on the next (elevator rides and stairs included), optimised. `odometry` maps a
// robot to its odometry samples (ordered by stamp).
building::BuildingSolution solveWithOdometryChain(
    const building::BuildingGraph& graph,
    const std::map<std::string, std::vector<sensor::OdometrySample>>& odometry);

struct RunFigures {
  std::string experiment;
  std::uint64_t seed = 0;
  std::string output_dir;
  double seconds = 0.0;  // the whole map job
  eval::Evaluation with;         // with inter-floor constraints
  eval::Evaluation without;      // floor graphs joined by odometry only (the paper's baseline)
  eval::Evaluation independent;  // every floor graph in its own frame (`storey map`'s "without")
  std::vector<ConstraintCheck> constraints;
};

struct Statistic {
  std::size_t count = 0;
  double mean = 0.0, std = 0.0;  // std: sample standard deviation (0 for one value)
  double worst = 0.0;            // the largest value
};
Statistic summarise(const std::vector<double>& values);

struct FloorRow {
  std::string floor;
  Statistic translation_without, rotation_without;  // m, rad; joined by odometry only
  Statistic translation_with, rotation_with;
  Statistic constraints;  // constraints touching the floor, per run
  // Signed heading error of those constraints (rad), over all runs: a bias here turns
  // the floor by about as much.
  Statistic constraint_rotation;
  std::size_t wrong = 0;  // wrong constraints touching the floor, all runs
  bool goal_met = false;  // every run within the goal
};

struct CorridorRow {
  std::string name, floor;
  double true_length = 0.0;
  Statistic error_without, error_with;          // signed, estimated / true - 1
  Statistic abs_error_without, abs_error_with;  // |estimated / true - 1|
  std::size_t unmeasured = 0;                   // runs where it was not measured
  bool goal = false;                            // judged against the corridor goal
  bool goal_met = false;                        // every run below the goal
};

struct ExperimentTable {
  ExperimentSpec spec;
  ExperimentGoals goals;
  std::vector<RunFigures> runs;  // by seed
  std::vector<FloorRow> floors;
  std::vector<CorridorRow> corridors;
  std::size_t constraints = 0, wrong = 0, unchecked = 0;
  std::size_t off_weak = 0;  // off by the fixed limits, but only along a weak direction as claimed
  double seconds = 0.0;  // wall time of the experiment
  // Goal lines, each "met" or "NOT met" with the figure behind it.
  std::vector<std::pair<std::string, bool>> verdicts;
};

// Builds the table of one experiment from its runs (also used by tests).
ExperimentTable summariseExperiment(const ExperimentSpec& spec, const ExperimentGoals& goals,
                                    std::vector<RunFigures> runs);

// Runs the experiments; writes every run's outputs, and <output_dir>/experiments.md,
// experiments.csv (one row per run and floor or corridor) and constraints.csv (every
// inter-floor constraint checked against truth). Throws std::invalid_argument
// for an unknown experiment or bad counts.
std::vector<ExperimentTable> runExperiments(const ExperimentOptions& options);

// The tables as Markdown (what `storey experiments` prints) and as CSV.
std::string toMarkdown(const std::vector<ExperimentTable>& tables);
std::string toCsv(const std::vector<ExperimentTable>& tables);
std::string constraintsCsv(const std::vector<ExperimentTable>& tables);

}  // namespace storey::tools
