#include "storey/mapping/tracker.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::mapping {

using geometry::Pose2;

namespace {

// Windows cover 3 σ of the prediction.
constexpr double kWindowSigmas = 3.0;
// χ²(3) at 99 %: the odometry since the anchor agrees with a match within this.
constexpr double kAgreementChi2 = 11.34;
// The running mean of NIS / 3 weighs the last ~10 matched scans; one step's share is capped
// (4 σ per axis: a stall or a wrong match moves the scale by a fraction, not a multiple).
constexpr double kScaleWeight = 0.1;
constexpr double kMaxStepScale = 16.0;
// An unmatched scan doubles the prediction's standard deviations.
constexpr double kUnmatchedVarianceFactor = 4.0;

double largestStddev(const Eigen::Matrix2d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance);
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

Eigen::Vector3d difference(const Pose2& a, const Pose2& b) {
  return Eigen::Vector3d(a.x() - b.x(), a.y() - b.y(), geometry::angleDiff(a.theta(), b.theta()));
}

double mahalanobis2(const Eigen::Vector3d& e, const Eigen::Matrix3d& covariance) {
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(covariance);
  if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return e.dot(ldlt.solve(e));
}

}  // namespace

Eigen::Matrix3d odometryCovariance(const Pose2& delta, const OdometryNoiseModel& m) {
  const double d = delta.translation().norm();
  const double st = std::max(m.min_translation_stddev, m.translation_per_meter * d);
  const double sr =
      std::max(m.min_rotation_stddev,
               m.rotation_per_meter * d + m.rotation_per_radian * std::abs(delta.theta()));
  return Eigen::Vector3d(st * st, st * st, sr * sr).asDiagonal();
}

Tracker::Tracker(OdometryNoiseModel model, TrackingWindows windows)
    : model_(model), windows_(windows) {}

void Tracker::start(const Pose2& pose, const Pose2& odometry, const Eigen::Matrix3d& covariance) {
  started_ = true;
  pose_ = anchor_pose_ = pose;
  odometry_ = anchor_odometry_ = odometry;
  covariance_ = anchor_covariance_ = covariance;
  agrees_ = true;
}

Eigen::Matrix3d Tracker::stepCovariance(const Pose2& delta) const {
  return scale_ * odometryCovariance(delta, model_);
}

TrackPrediction Tracker::predictFrom(const Pose2& pose, const Eigen::Matrix3d& covariance,
                                     const Pose2& from_odometry, const Pose2& odometry) const {
  const Pose2 delta = from_odometry.between(odometry);
  TrackPrediction p;
  p.pose = pose * delta;
  const Eigen::Matrix3d step = stepCovariance(delta);
  p.covariance = geometry::composeCovariance(pose, covariance, delta, step);
  p.step_covariance = geometry::composeCovariance(pose, Eigen::Matrix3d::Zero(), delta, step);
  setWindows(&p);
  return p;
}

void Tracker::setWindows(TrackPrediction* p) const {
  p->linear_window =
      std::clamp(kWindowSigmas * largestStddev(p->covariance.topLeftCorner<2, 2>()),
                 windows_.min_linear, std::max(windows_.min_linear, windows_.max_linear));
  p->angular_window =
      std::clamp(kWindowSigmas * std::sqrt(std::max(0.0, p->covariance(2, 2))),
                 windows_.min_angular, std::max(windows_.min_angular, windows_.max_angular));
}

TrackPrediction Tracker::predict(const Pose2& odometry) const {
  return predictFrom(pose_, covariance_, odometry_, odometry);
}

std::optional<TrackPrediction> Tracker::predictFromAnchor(const Pose2& odometry) const {
  if (agrees_) return std::nullopt;
  TrackPrediction p = predictFrom(anchor_pose_, anchor_covariance_, anchor_odometry_, odometry);
  p.from_anchor = true;
  return p;
}

bool Tracker::check(const Pose2& odometry, const Pose2& pose, const Eigen::Matrix3d& covariance,
                    const TrackPrediction& prediction) {
  // How far the model's prediction was off, in its own units (the model unscaled: the
  // scale estimates what the model misses).
  const Pose2 delta = (prediction.from_anchor ? anchor_odometry_ : odometry_).between(odometry);
  const Pose2& from = prediction.from_anchor ? anchor_pose_ : pose_;
  const Eigen::Matrix3d& from_covariance =
      prediction.from_anchor ? anchor_covariance_ : covariance_;
  const Eigen::Matrix3d unscaled =
      geometry::composeCovariance(from, from_covariance, delta, odometryCovariance(delta, model_)) +
      covariance;
  const double nis = mahalanobis2(difference(pose, prediction.pose), unscaled);
  scale_ = std::max(
      1.0, (1.0 - kScaleWeight) * scale_ + kScaleWeight * std::min(kMaxStepScale, nis / 3.0));
  // The odometry since the anchor, or its step since the last scan, against the match.
  const TrackPrediction from_anchor =
      predictFrom(anchor_pose_, anchor_covariance_, anchor_odometry_, odometry);
  if (mahalanobis2(difference(pose, from_anchor.pose), from_anchor.covariance + covariance) <=
      kAgreementChi2)
    return true;
  const Pose2 step = pose_.between(pose);
  const bool informative = step.translation().norm() >= windows_.informative_translation ||
                           std::abs(step.theta()) >= windows_.informative_rotation;
  const TrackPrediction from_last = predictFrom(pose_, covariance_, odometry_, odometry);
  return informative && mahalanobis2(difference(pose, from_last.pose),
                                     from_last.covariance + covariance) <= kAgreementChi2;
}

void Tracker::moveTo(const Pose2& odometry, const Pose2& pose, const Eigen::Matrix3d& covariance,
                     bool agrees) {
  pose_ = pose;
  odometry_ = odometry;
  covariance_ = covariance;
  agrees_ = agrees;
  if (agrees) {
    anchor_pose_ = pose;
    anchor_odometry_ = odometry;
    anchor_covariance_ = covariance;
  }
}

void Tracker::unmatched(const Pose2& odometry, const TrackPrediction& prediction) {
  pose_ = prediction.pose;
  odometry_ = odometry;
  covariance_ = kUnmatchedVarianceFactor * prediction.covariance;
}

void Tracker::correct(const Pose2& correction) {
  pose_ = correction * pose_;
  anchor_pose_ = correction * anchor_pose_;
  // World-frame covariances turn with the map.
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  turn.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(correction.theta()).toRotationMatrix();
  covariance_ = turn * covariance_ * turn.transpose();
  anchor_covariance_ = turn * anchor_covariance_ * turn.transpose();
}

}  // namespace storey::mapping
