// Comparing an estimated building trajectory with ground truth: one global SE(2) fit,
// per-floor residual alignment and trajectory error, corridor length ratios, and the
// relation-based error of Kuemmerle et al. 2009 ("On measuring the accuracy of SLAM
// algorithms"). All poses are in the building frame.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "storey/eval/trajectory.h"
#include "storey/geometry/pose2.h"

namespace storey::eval {

// One ground-truth pose and the estimate at the same stamp.
struct PosePair {
  std::string robot;
  std::string floor;  // the true floor
  double stamp = 0.0;
  geometry::Pose2 estimate;
  geometry::Pose2 truth;
};

// Matches estimates to truth by robot and stamp: an estimate within `stamp_tolerance`
// seconds is taken as is, otherwise the estimate is interpolated between its neighbours
// when they are at most `max_gap` seconds apart; unmatched truth poses are skipped
// (counted in *unmatched).
std::vector<PosePair> associate(const std::vector<PoseRow>& estimate,
                                const std::vector<PoseRow>& truth, double stamp_tolerance = 1e-3,
                                double max_gap = 1.0, std::size_t* unmatched = nullptr);

// The rigid transform T minimising sum w_i |T * from_i - to_i|^2 (closed form). Needs
// at least two distinct points; throws std::invalid_argument otherwise.
geometry::Pose2 alignPoints(const std::vector<Eigen::Vector2d>& from,
                            const std::vector<Eigen::Vector2d>& to);

struct FloorError {
  std::string floor;
  std::size_t poses = 0;
  geometry::Pose2 residual;  // best map of this floor's (globally aligned) estimate onto truth
  double residual_translation = 0.0;  // how far it moves the floor's centroid, m
  double residual_rotation = 0.0;     // |angle|, rad
  double ate_rmse = 0.0;              // after the global alignment, m
  double ate_mean = 0.0;
  double ate_max = 0.0;
};

struct RelationError {
  int step = 1;  // relations between pose i and i+step of the same robot
  std::size_t count = 0;
  double translation_mean = 0.0, translation_std = 0.0;  // m
  double rotation_mean = 0.0, rotation_std = 0.0;        // rad
};

// A named straight distance between two points of a floor (building frame).
struct CorridorSpec {
  std::string name;
  std::string floor;
  Eigen::Vector2d from = Eigen::Vector2d::Zero();
  Eigen::Vector2d to = Eigen::Vector2d::Zero();
};

struct CorridorError {
  std::string name;
  std::string floor;
  bool measured = false;                    // false when the robot never came near both ends
  double stamp_from = 0.0, stamp_to = 0.0;  // the nearest true poses to the two points
  double true_length = 0.0, estimated_length = 0.0;
  double ratio = 0.0;  // estimated / true
};

struct EvaluateOptions {
  double stamp_tolerance = 1e-3;
  double max_gap = 1.0;
  std::vector<int> relation_steps = {1, 10};
  double corridor_max_distance =
      2.0;  // an end point farther than this from the trajectory is not measured
};

struct Evaluation {
  std::size_t matched = 0, unmatched = 0;
  geometry::Pose2 global_alignment;  // maps the estimate into the truth frame
  double ate_rmse = 0.0;             // all poses, after the global alignment
  std::vector<FloorError> floors;
  std::vector<RelationError> relations;
  std::vector<CorridorError> corridors;
};

Evaluation evaluate(const std::vector<PoseRow>& estimate, const std::vector<PoseRow>& truth,
                    const std::vector<CorridorSpec>& corridors = {},
                    const EvaluateOptions& options = {});

std::string toJson(const Evaluation& evaluation);
std::string toTable(const Evaluation& evaluation);

}  // namespace storey::eval
