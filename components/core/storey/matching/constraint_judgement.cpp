#include "storey/matching/constraint_judgement.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::matching {

ConstraintJudgement judgeConstraint(const geometry::Pose2& measured, const geometry::Pose2& truth,
                                    const Eigen::Matrix3d& information,
                                    const WrongConstraintLimits& limits) {
  ConstraintJudgement j;
  const Eigen::Vector2d error = measured.translation() - truth.translation();
  j.translation = error.norm();
  j.signed_rotation = geometry::angleDiff(measured.theta(), truth.theta());
  j.rotation = std::abs(j.signed_rotation);

  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(information.topLeftCorner<2, 2>());
  const double weakest = eigen.eigenvalues()(0);  // ascending
  const Eigen::Vector2d weak = eigen.eigenvectors().col(0);
  j.weak_sigma = weakest > 0.0 ? 1.0 / std::sqrt(weakest) : std::numeric_limits<double>::infinity();
  j.along_weak = std::abs(error.dot(weak));
  j.across_weak = std::abs(error.x() * weak.y() - error.y() * weak.x());

  j.off = j.translation > limits.translation || j.rotation > limits.rotation;
  // The along part is scaled to the fixed limit, so an isotropic claim (whose 3 sigma is
  // below the limit) is judged exactly as by the fixed limits.
  const double along_limit = std::max(limits.translation, limits.weak_sigmas * j.weak_sigma);
  const double along_scaled = j.along_weak * limits.translation / along_limit;
  j.wrong = std::hypot(along_scaled, j.across_weak) > limits.translation || j.rotation > limits.rotation;
  return j;
}

}  // namespace storey::matching
