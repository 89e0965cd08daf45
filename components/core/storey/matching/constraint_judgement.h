// Whether an inter-floor constraint is wrong, judged against the truth by what it claims.
// A constraint from scans that see only a corridor's two walls says so in its information
// (weak along the corridor, docs/floor_matcher.md); an error along that direction within
// a few of its claimed sigmas is what it said it might be, not a false claim. Across the
// weak direction, and for constraints that claim to know both directions, the fixed
// limits apply (0.3 m, 2 deg: the matcher's scenario threshold).
#pragma once

#include <Eigen/Core>

#include "storey/geometry/pose2.h"

namespace storey::matching {

struct WrongConstraintLimits {
  double translation = 0.3;                // m
  double rotation = 2.0 * M_PI / 180.0;    // rad
  double weak_sigmas = 3.0;  // along the weak direction: max(translation, this × claimed sigma)
};

struct ConstraintJudgement {
  double translation = 0.0;     // m, |measured - true| of the node's position
  double along_weak = 0.0;      // m, its part along the weakest claimed direction
  double across_weak = 0.0;     // m, its part across it
  double rotation = 0.0;        // rad, |heading error|
  double signed_rotation = 0.0;  // rad, measured - true
  double weak_sigma = 0.0;      // m, the largest translational sigma the information claims
  bool off = false;    // beyond the fixed limits in some direction, whatever it claims
  bool wrong = false;  // beyond what it claims (see above)
};

// `measured` and `truth` are the same node's pose in the frame of the constraint's other
// (reference) node; `information` is over (dx, dy, dθ) in that frame.
ConstraintJudgement judgeConstraint(const geometry::Pose2& measured, const geometry::Pose2& truth,
                                    const Eigen::Matrix3d& information,
                                    const WrongConstraintLimits& limits = {});

}  // namespace storey::matching
