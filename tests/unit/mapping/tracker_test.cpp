// The tracking motion model (mapping/tracker.h): windows from the propagated odometry
// covariance, the noise scale learnt from the matches, and the anchor for odometry that
// stalls and catches up.
#include "storey/mapping/tracker.h"

#include <gtest/gtest.h>

#include <cmath>

namespace storey::mapping {
namespace {

using geometry::Pose2;

TrackingWindows windows() { return TrackingWindows{0.1, 0.05, 1.5, M_PI / 2}; }

TEST(Tracker, TheWindowCoversThreeSigmaOfTheOdometrySinceTheLastMatch) {
  OdometryNoiseModel model;
  Tracker tracker(model, windows());
  tracker.start(Pose2(), Pose2(), Eigen::Matrix3d::Zero());
  // One metre straight: 5 cm per axis, 0.035 rad of heading.
  const TrackPrediction one = tracker.predict(Pose2(1, 0, 0));
  EXPECT_NEAR(one.pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(one.linear_window, 3 * 0.05, 1e-9);
  EXPECT_NEAR(one.angular_window, 3 * 0.035, 1e-9);
  // Four metres: wider, capped at the maximum.
  const TrackPrediction four = tracker.predict(Pose2(4, 0, 0));
  EXPECT_GT(four.linear_window, one.linear_window);
  const TrackPrediction far = tracker.predict(Pose2(40, 0, 0));
  EXPECT_DOUBLE_EQ(far.linear_window, 1.5);
  // Standing still: the floors.
  const TrackPrediction still = tracker.predict(Pose2());
  EXPECT_DOUBLE_EQ(still.linear_window, 0.1);
  EXPECT_DOUBLE_EQ(still.angular_window, 0.05);
}

TEST(Tracker, AnUnmatchedScanWidensTheNextSearch) {
  Tracker tracker(OdometryNoiseModel{}, windows());
  tracker.start(Pose2(), Pose2(), Eigen::Matrix3d::Zero());
  const TrackPrediction first = tracker.predict(Pose2(1, 0, 0));
  tracker.unmatched(Pose2(1, 0, 0), first);
  const TrackPrediction next = tracker.predict(Pose2(1, 0, 0));    // no motion since
  EXPECT_NEAR(next.linear_window, 2 * first.linear_window, 0.01);  // and a standing step's floor
  EXPECT_NEAR(next.pose.x(), 1.0, 1e-12);
}

TEST(Tracker, OdometryNoisierThanItsModelScalesTheModelUp) {
  OdometryNoiseModel model;
  Tracker tracker(model, windows());
  tracker.start(Pose2(), Pose2(), Eigen::Matrix3d::Zero());
  const Eigen::Matrix3d match = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  // Odometry that is right: the scale stays 1.
  Pose2 truth, odometry;
  for (int i = 0; i < 30; ++i) {
    truth = truth * Pose2(1, 0, 0);
    odometry = odometry * Pose2(1, 0, 0);
    const TrackPrediction p = tracker.predict(odometry);
    tracker.moveTo(odometry, truth, match, tracker.check(odometry, truth, match, p));
  }
  EXPECT_DOUBLE_EQ(tracker.noiseScale(), 1.0);
  // Odometry 20 % short every metre (4 σ of the model along the step, NIS about 15): the
  // scale grows towards NIS / 3, and the windows with it.
  const double before = tracker.predict(odometry * Pose2(1, 0, 0)).linear_window;
  for (int i = 0; i < 60; ++i) {
    truth = truth * Pose2(1, 0, 0);
    odometry = odometry * Pose2(0.8, 0, 0);
    const TrackPrediction p = tracker.predict(odometry);
    tracker.moveTo(odometry, truth, match, tracker.check(odometry, truth, match, p));
  }
  EXPECT_GT(tracker.noiseScale(), 3.0);
  EXPECT_LT(tracker.noiseScale(), 8.0);
  EXPECT_GT(tracker.predict(odometry * Pose2(1, 0, 0)).linear_window, 1.8 * before);
}

TEST(Tracker, OdometryThatStalledIsPredictedFromWhereItLastAgreedOnceItCatchesUp) {
  Tracker tracker(OdometryNoiseModel{}, windows());
  tracker.start(Pose2(), Pose2(), Eigen::Matrix3d::Zero());
  const Eigen::Matrix3d match = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  EXPECT_FALSE(tracker.predictFromAnchor(Pose2()).has_value());
  // The odometry holds at 0 while the scans find the robot at 0.2 and 0.4 m.
  for (double x : {0.2, 0.4}) {
    const TrackPrediction p = tracker.predict(Pose2());
    const bool agrees = tracker.check(Pose2(), Pose2(x, 0, 0), match, p);
    EXPECT_FALSE(agrees);
    tracker.moveTo(Pose2(), Pose2(x, 0, 0), match, agrees);
  }
  // It catches up: at 0.6 m it reports 0.6 m. From the last scan that counts the 0.4 m twice;
  // from the anchor (the start, where it last agreed) it is right.
  const Pose2 caught_up(0.6, 0, 0);
  EXPECT_NEAR(tracker.predict(caught_up).pose.x(), 1.0, 1e-12);
  const auto anchor = tracker.predictFromAnchor(caught_up);
  ASSERT_TRUE(anchor.has_value());
  EXPECT_TRUE(anchor->from_anchor);
  EXPECT_NEAR(anchor->pose.x(), 0.6, 1e-12);
  const bool agrees = tracker.check(caught_up, Pose2(0.6, 0, 0), match, *anchor);
  EXPECT_TRUE(agrees);
  tracker.moveTo(caught_up, Pose2(0.6, 0, 0), match, agrees);
  EXPECT_FALSE(tracker.predictFromAnchor(Pose2(0.8, 0, 0)).has_value());
}

TEST(Tracker, ACorrectionMovesTheTrackedPosesWithTheMap) {
  Tracker tracker(OdometryNoiseModel{}, windows());
  tracker.start(Pose2(1, 0, 0), Pose2(), Eigen::Vector3d(0.01, 0.0001, 0.001).asDiagonal());
  tracker.correct(Pose2(0, 0, M_PI / 2));
  EXPECT_NEAR(tracker.pose().x(), 0.0, 1e-12);
  EXPECT_NEAR(tracker.pose().y(), 1.0, 1e-12);
  // The covariance turned with it: the larger variance now along y.
  const TrackPrediction p = tracker.predict(Pose2());
  EXPECT_GT(p.covariance(1, 1), p.covariance(0, 0));
}

}  // namespace
}  // namespace storey::mapping
