#include "storey/eval/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "test_support.h"

namespace storey::eval {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A 10 m x 4 m rectangle walked by "r" on floor A, then the same on floor B.
std::vector<PoseRow> squareWalk() {
  std::vector<PoseRow> rows;
  double t = 0.0;
  for (const char* floor : {"A", "B"}) {
    for (int i = 0; i < 40; ++i) {
      const double s = i / 40.0 * 28.0;  // perimeter 28 m
      double x, y, th;
      if (s < 10)
        x = s, y = 0, th = 0;
      else if (s < 14)
        x = 10, y = s - 10, th = kPi / 2;
      else if (s < 24)
        x = 24 - s, y = 4, th = kPi;
      else
        x = 0, y = 28 - s, th = -kPi / 2;
      rows.push_back({t, "r", floor, geometry::Pose2(x, y, th), floor[0] == 'A' ? 0.0 : 3.0});
      t += 1.0;
    }
  }
  return rows;
}

std::vector<PoseRow> transformed(std::vector<PoseRow> rows, const geometry::Pose2& T,
                                 const std::string& only_floor = "") {
  for (auto& r : rows)
    if (only_floor.empty() || r.floor == only_floor) r.pose = T * r.pose;
  return rows;
}

TEST(AlignPoints, RecoversAKnownRigidTransform) {
  const geometry::Pose2 T(3.0, -2.0, 0.7);
  std::vector<Eigen::Vector2d> a = {{0, 0}, {1, 0}, {0, 2}, {5, 5}}, b;
  for (const auto& p : a) b.push_back(T.transformPoint(p));
  const geometry::Pose2 fit = alignPoints(a, b);
  EXPECT_NEAR(fit.x(), 3.0, 1e-12);
  EXPECT_NEAR(fit.y(), -2.0, 1e-12);
  EXPECT_NEAR(fit.theta(), 0.7, 1e-12);
  EXPECT_THROW(alignPoints({{1, 1}}, {{2, 2}}), std::invalid_argument);
  EXPECT_THROW(alignPoints({{1, 1}, {1, 1}}, {{2, 2}, {2, 2}}), std::invalid_argument);
}

TEST(AlignPoints, IsTheLeastSquaresFitForNoisyPoints) {
  // Symmetric noise: +e and -e on mirrored points cancel, so the fit is exact.
  std::vector<Eigen::Vector2d> a = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  std::vector<Eigen::Vector2d> b = {{1, 0.1}, {-1, -0.1}, {-0.1, 1}, {0.1, -1}};
  const geometry::Pose2 fit = alignPoints(a, b);
  EXPECT_NEAR(fit.theta(), std::atan(0.1), 1e-12);
  EXPECT_NEAR(fit.x(), 0.0, 1e-12);
  EXPECT_NEAR(fit.y(), 0.0, 1e-12);
}

TEST(Evaluate, PerfectEstimateInAnotherFrameHasZeroError) {
  const auto truth = squareWalk();
  const auto estimate = transformed(truth, geometry::Pose2(5.0, 1.0, 0.3));
  const Evaluation e = evaluate(estimate, truth);
  EXPECT_EQ(e.matched, truth.size());
  EXPECT_EQ(e.unmatched, 0u);
  EXPECT_NEAR(e.ate_rmse, 0.0, 1e-9);
  EXPECT_NEAR(e.global_alignment.theta(), -0.3, 1e-12);
  ASSERT_EQ(e.floors.size(), 2u);
  for (const auto& f : e.floors) {
    EXPECT_NEAR(f.residual_translation, 0.0, 1e-9);
    EXPECT_NEAR(f.residual_rotation, 0.0, 1e-12);
  }
  for (const auto& r : e.relations) EXPECT_NEAR(r.translation_mean, 0.0, 1e-9);
}

TEST(Evaluate, OneFloorRotatedShowsUpOnThatFloor) {
  const auto truth = squareWalk();
  // Floor B turned by 2 degrees about its centroid (5, 2): the global fit shares the error,
  // the per-floor residuals must together undo the 2 degrees.
  const geometry::Pose2 turn =
      geometry::Pose2(5, 2, 0) * geometry::Pose2(0, 0, 2 * kPi / 180) * geometry::Pose2(-5, -2, 0);
  const Evaluation e = evaluate(transformed(truth, turn, "B"), truth);
  ASSERT_EQ(e.floors.size(), 2u);
  EXPECT_NEAR(e.floors[0].residual_rotation + e.floors[1].residual_rotation, 2 * kPi / 180, 1e-9);
  // Equal pose counts: the global fit splits the rotation evenly.
  EXPECT_NEAR(e.floors[1].residual_rotation, kPi / 180, 1e-6);
  EXPECT_GT(e.floors[1].ate_rmse, 0.05);
}

TEST(Evaluate, RelationErrorsOfAKnownDrift) {
  // The estimate adds 0.1 m forward per step along a straight line: every consecutive
  // relation is 0.1 m off, relations 10 steps apart are 1 m off.
  std::vector<PoseRow> truth, estimate;
  for (int i = 0; i < 50; ++i) {
    truth.push_back({double(i), "r", "A", geometry::Pose2(i, 0, 0), 0});
    estimate.push_back({double(i), "r", "A", geometry::Pose2(1.1 * i, 0, 0), 0});
  }
  EvaluateOptions options;
  options.relation_steps = {1, 10};
  const Evaluation e = evaluate(estimate, truth, {}, options);
  ASSERT_EQ(e.relations.size(), 2u);
  EXPECT_EQ(e.relations[0].count, 49u);
  EXPECT_NEAR(e.relations[0].translation_mean, 0.1, 1e-9);
  EXPECT_NEAR(e.relations[0].translation_std, 0.0, 1e-9);
  EXPECT_EQ(e.relations[1].count, 40u);
  EXPECT_NEAR(e.relations[1].translation_mean, 1.0, 1e-9);
  EXPECT_NEAR(e.relations[0].rotation_mean, 0.0, 1e-12);
}

TEST(Evaluate, CorridorShortenedByTenPercent) {
  std::vector<PoseRow> truth, estimate;
  for (int i = 0; i <= 100; ++i) {
    truth.push_back({double(i), "r", "A", geometry::Pose2(i, 0, 0), 0});
    estimate.push_back({double(i), "r", "A", geometry::Pose2(0.9 * i, 0, 0), 0});
  }
  const std::vector<CorridorSpec> corridors = {{"long", "A", {10.2, 0.3}, {89.9, -0.2}},
                                               {"elsewhere", "A", {10, 50}, {20, 50}}};
  const Evaluation e = evaluate(estimate, truth, corridors);
  ASSERT_EQ(e.corridors.size(), 2u);
  ASSERT_TRUE(e.corridors[0].measured);
  EXPECT_DOUBLE_EQ(e.corridors[0].stamp_from, 10.0);
  EXPECT_DOUBLE_EQ(e.corridors[0].stamp_to, 90.0);
  EXPECT_NEAR(e.corridors[0].true_length, 80.0, 1e-9);
  EXPECT_NEAR(e.corridors[0].ratio, 0.9, 1e-9);
  EXPECT_FALSE(e.corridors[1].measured);
}

TEST(Associate, InterpolatesBetweenEstimatesAndCountsTheRest) {
  const std::vector<PoseRow> truth = {{1.0, "r", "A", geometry::Pose2(1, 0, 0), 0},
                                      {1.5, "r", "A", geometry::Pose2(1.5, 0, 0), 0},
                                      {9.0, "r", "A", geometry::Pose2(9, 0, 0), 0},
                                      {1.0, "q", "A", geometry::Pose2(0, 0, 0), 0}};
  const std::vector<PoseRow> estimate = {{1.0, "r", "A", geometry::Pose2(10, 0, 0), 0},
                                         {2.0, "r", "A", geometry::Pose2(20, 0, 0), 0},
                                         {5.0, "r", "A", geometry::Pose2(50, 0, 0), 0}};
  std::size_t unmatched = 0;
  const auto pairs = associate(estimate, truth, 1e-3, 1.0, &unmatched);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_DOUBLE_EQ(pairs[0].estimate.x(), 10.0);
  EXPECT_DOUBLE_EQ(pairs[1].estimate.x(), 15.0);  // halfway between 1 s and 2 s
  EXPECT_EQ(unmatched, 2u);  // 9 s is after the last estimate; robot q has none
}

TEST(TrajectoryCsv, RoundTripsAndNamesBadCells) {
  const std::string dir = test::makeTempDir("eval_csv");
  const auto rows = squareWalk();
  writeTrajectoryCsv(dir + "/t.csv", rows);
  const auto back = readTrajectoryCsv(dir + "/t.csv");
  ASSERT_EQ(back.size(), rows.size());
  EXPECT_NEAR(back[17].pose.theta(), rows[17].pose.theta(), 1e-9);
  EXPECT_EQ(back[45].floor, "B");
  try {
    parseTrajectoryCsv("stamp,robot,floor,x,y,theta,z\n0,r,A,1,2,0,0\n1,r,A,1,abc,0,0\n",
                       "bad.csv");
    FAIL() << "expected an error";
  } catch (const TrajectoryError& e) {
    EXPECT_STREQ(e.what(), "bad.csv:3: y: expected a finite number, got 'abc'");
  }
  EXPECT_THROW(parseTrajectoryCsv("t,x\n", "h.csv"), TrajectoryError);
  EXPECT_THROW(parseTrajectoryCsv("stamp,robot,floor,x,y,theta,z\n0,r,A,1,2\n", "c.csv"),
               TrajectoryError);
}

}  // namespace
}  // namespace storey::eval
