// Where the next scan is expected and how far to search for it: the odometry motion model
// of the front end's tracking.
//
// The last tracked scan (its pose relative to the local map, with covariance) and the
// odometry since predict the next scan; the odometry model's covariance, propagated from
// there, sets the correlative search window (3 σ, between a floor and a cap). A scan that
// is not matched leaves the prediction standing with its uncertainty grown, so the next
// search is wider instead of the scan being refused.
//
// The model is checked against what the scans say: each match's innovation (matched pose
// against prediction) is normalised by the predicted covariance (NIS, 3 on average when
// the model is right). A running mean above 3 scales the model's covariance up by as much,
// so odometry noisier than configured widens the windows and weakens the odometry edges;
// the configured model is never made more confident.
//
// Odometry that stalls or lags catches up later in one step: its motion since the last
// scan where it agreed with the matches (the anchor) is then right, while its step since
// the last scan counts again what the scans already found. While the matches disagree with
// the odometry since the anchor, the anchor's prediction is offered as a second hypothesis.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "storey/common/shipped_config.h"
#include "storey/geometry/pose2.h"

namespace storey::mapping {

// The shipped file's front-end values (config/floor_mapper.yaml, `slam`), the defaults below.
namespace shipped_slam = shipped::floor_mapper::slam;

// Standard deviations of odometry per step, for the odometry edges' information and the
// tracking windows.
struct OdometryNoiseModel {
  // m per m travelled
  double translation_per_meter = shipped_slam::odometry_noise::translation_per_meter;
  // rad per m travelled
  double rotation_per_meter = shipped_slam::odometry_noise::rotation_per_meter;
  // rad per rad turned
  double rotation_per_radian = shipped_slam::odometry_noise::rotation_per_radian;
  double min_translation_stddev = 0.01;
  double min_rotation_stddev = 0.005;
};

// The covariance of an odometry step `delta` (in its start's frame) under the model.
Eigen::Matrix3d odometryCovariance(const geometry::Pose2& delta, const OdometryNoiseModel& model);

struct TrackingWindows {
  // The search window's half widths: 3 σ of the prediction, at least the minimum (the
  // odometry model may be optimistic) and at most the maximum (m, rad).
  double min_linear = 0.3, min_angular = 0.35;
  double max_linear = 1.5, max_angular = M_PI / 2;
  // A step at least this long (m) or this large a turn (rad) shows whether the odometry
  // works (the node spacing): a standing robot agrees with odometry that stalled.
  double informative_translation = 0.2, informative_rotation = 0.17;
};

struct TrackPrediction {
  geometry::Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // world frame
  // The odometry step's own share (world frame): what the odometry knows of the motion
  // since the tracked scan, whatever the map knew of that scan.
  Eigen::Matrix3d step_covariance = Eigen::Matrix3d::Zero();
  double linear_window = 0.0, angular_window = 0.0;
  bool from_anchor = false;
};

class Tracker {
 public:
  Tracker(OdometryNoiseModel model, TrackingWindows windows);

  // A run starts (first scan, relocalisation): the pose of the scan at `odometry`, known to
  // `covariance` relative to the map.
  void start(const geometry::Pose2& pose, const geometry::Pose2& odometry,
             const Eigen::Matrix3d& covariance);
  bool started() const { return started_; }

  // The scan at `odometry`, predicted from the last tracked scan.
  TrackPrediction predict(const geometry::Pose2& odometry) const;
  // The same from the anchor, while the odometry disagrees with the matches since it and
  // the two predictions are farther apart than the window searches; otherwise none.
  std::optional<TrackPrediction> predictFromAnchor(const geometry::Pose2& odometry) const;

  // The scan at `odometry`, found from `prediction` at `pose` (covariance relative to the
  // map): updates the model's scale, and returns whether the odometry agrees with it (χ² at
  // 99 %): its motion since the anchor, or its step since the last tracked scan when that
  // step moved the robot enough to tell (after a slip or a jump the odometry goes on from a
  // new offset, and agrees again step by step).
  bool check(const geometry::Pose2& odometry, const geometry::Pose2& pose,
             const Eigen::Matrix3d& covariance, const TrackPrediction& prediction);
  // Tracking goes on from the scan at `odometry`, at `pose` known to `covariance` relative
  // to the map; it becomes the anchor when the odometry agreed with it.
  void moveTo(const geometry::Pose2& odometry, const geometry::Pose2& pose,
              const Eigen::Matrix3d& covariance, bool agrees);
  // The scan at `odometry` was not matched: tracking goes on from the prediction, its
  // covariance grown (σ doubled: the scan lay outside the window, or saw little of the map).
  void unmatched(const geometry::Pose2& odometry, const TrackPrediction& prediction);

  // The map moved under the tracked poses (optimisation): `correction` applied to both.
  void correct(const geometry::Pose2& correction);

  // The odometry model's covariance for a step, scaled by what the matches showed.
  Eigen::Matrix3d stepCovariance(const geometry::Pose2& delta) const;
  double noiseScale() const { return scale_; }  // ≥ 1: variance factor on the model
  const geometry::Pose2& pose() const { return pose_; }
  const geometry::Pose2& odometry() const { return odometry_; }
  bool odometryAgrees() const { return agrees_; }

 private:
  TrackPrediction predictFrom(const geometry::Pose2& pose, const Eigen::Matrix3d& covariance,
                              const geometry::Pose2& from_odometry,
                              const geometry::Pose2& odometry) const;
  void setWindows(TrackPrediction* p) const;

  OdometryNoiseModel model_;
  TrackingWindows windows_;
  bool started_ = false;
  geometry::Pose2 pose_, odometry_;
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
  geometry::Pose2 anchor_pose_, anchor_odometry_;
  Eigen::Matrix3d anchor_covariance_ = Eigen::Matrix3d::Zero();
  bool agrees_ = true;  // the odometry agreed with the matches since the anchor
  double scale_ = 1.0;  // running mean of NIS / 3, at least 1
};

}  // namespace storey::mapping
