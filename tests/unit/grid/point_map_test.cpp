// PointMap: cell means and normals, the point-to-line residual's derivative, and the
// alignment it gives (below the map's cell, not pulled towards where the map stops).
#include "storey/grid/point_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace storey::grid {
namespace {

using geometry::Pose2;

// Points along the segment a-b every `spacing`, with Gaussian noise across it.
void addWall(std::vector<Eigen::Vector2d>* points, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
             double spacing, double noise, std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, noise);
  const Eigen::Vector2d d = (b - a).normalized();
  const Eigen::Vector2d normal(-d.y(), d.x());
  const int count = static_cast<int>((b - a).norm() / spacing);
  for (int i = 0; i <= count; ++i) points->push_back(a + d * (i * spacing) + normal * (noise > 0 ? n(*rng) : 0.0));
}

// A room with a pillar: walls in both directions, so an alignment is fully determined.
std::vector<Eigen::Vector2d> room(double spacing, double noise, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector2d> p;
  addWall(&p, {0, 0}, {8, 0}, spacing, noise, &rng);
  addWall(&p, {8, 0}, {8, 5}, spacing, noise, &rng);
  addWall(&p, {8, 5}, {0, 5}, spacing, noise, &rng);
  addWall(&p, {0, 5}, {0, 0}, spacing, noise, &rng);
  addWall(&p, {3, 2}, {4, 2}, spacing, noise, &rng);
  addWall(&p, {4, 2}, {4, 3}, spacing, noise, &rng);
  return p;
}

TEST(PointMap, CellMeansAverageNoiseAndWallsGetTheirNormals) {
  const PointMap map(room(0.01, 0.01, 1), 0.05, 0.2);
  ASSERT_FALSE(map.empty());
  int wall_cells = 0;
  for (const auto& cell : map.cells()) {
    // Cells on the long wall y = 0, away from the corners.
    if (std::abs(cell.mean.y()) > 0.1 || cell.mean.x() < 0.5 || cell.mean.x() > 7.5) continue;
    ++wall_cells;
    // A wall on a cell border is split into two rows whose means lie on either side of
    // it (by about 0.8 σ); pairing with the nearest keeps that noise, not a bias.
    EXPECT_LT(std::abs(cell.mean.y()), 0.04);  // 4 σ: a split cell may hold one point
    ASSERT_FALSE(cell.normal.isZero());
    EXPECT_GT(std::abs(cell.normal.y()), 0.99);
  }
  EXPECT_GT(wall_cells, 100);
  // The corner (0, 0): no single line there.
  const PointMap::Cell* corner = map.nearest({0.0, 0.0}, 0.03);
  ASSERT_NE(corner, nullptr);
  EXPECT_TRUE(corner->normal.isZero());
  EXPECT_EQ(map.nearest({4.0, 1.0}, 0.15), nullptr);  // nothing within reach in the open
}

TEST(PointMap, CellMeansAverageTheNoiseOfAWallInsideOneRow) {
  std::mt19937_64 rng(6);
  std::vector<Eigen::Vector2d> points;
  addWall(&points, {0.0, 0.025}, {4.0, 0.025}, 0.002, 0.005, &rng);  // 25 points per cell
  const PointMap map(points, 0.05, 0.2);
  double worst = 0.0;
  for (const auto& cell : map.cells())
    if (cell.mean.x() > 0.2 && cell.mean.x() < 3.8) worst = std::max(worst, std::abs(cell.mean.y() - 0.025));
  EXPECT_LT(worst, 0.004);  // σ/√25 = 1 mm per cell; the worst of 72 cells
}

TEST(PointMap, PointToLineJacobianMatchesNumericDerivative) {
  PointMap::Cell cell;
  cell.mean = Eigen::Vector2d(2.0, 1.0);
  cell.normal = Eigen::Vector2d(0.6, 0.8);
  const Eigen::Vector2d point(1.3, -0.7);
  for (const Pose2& pose : {Pose2(0.1, 0.2, 0.3), Pose2(-1.0, 2.0, -2.5), Pose2(0.0, 0.0, 0.0)}) {
    Eigen::RowVector3d analytic;
    pointToLineResidual(cell, pose, point, &analytic);
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d(k) = h;
      const double plus = pointToLineResidual(
          cell, Pose2(pose.x() + d.x(), pose.y() + d.y(), pose.theta() + d.z()), point, nullptr);
      const double minus = pointToLineResidual(
          cell, Pose2(pose.x() - d.x(), pose.y() - d.y(), pose.theta() - d.z()), point, nullptr);
      EXPECT_NEAR(analytic(k), (plus - minus) / (2 * h), 1e-7) << "component " << k;
    }
  }
}

TEST(PointMap, AlignmentRecoversAnOffsetBelowTheCell) {
  // The map from noisy dense points; the "scan" another noisy sample of the same room,
  // expressed in a frame offset by less than a cell.
  const PointMap map(room(0.01, 0.01, 2), 0.05, 0.2);
  const Pose2 truth(0.03, -0.02, 0.007);  // 0.4°
  std::vector<Eigen::Vector2d> scan;
  for (const auto& p : room(0.05, 0.01, 3)) scan.push_back(truth.inverse().transformPoint(p));
  const PointAlignment fit = alignToPoints(map, scan, Pose2(), PointAlignmentOptions{});
  EXPECT_LT((fit.pose.translation() - truth.translation()).norm(), 0.002);
  EXPECT_LT(std::abs(fit.pose.theta() - truth.theta()), 0.0004);  // 0.02°
  EXPECT_GT(fit.weight_sum, 0.8 * static_cast<double>(scan.size()));
}

TEST(PointMap, PointsBeyondTheMapsWallsDoNotPullTheAlignment) {
  // The map has a corridor's walls up to x = 5 and its end wall; the scan, taken at the
  // true pose, sees the walls on to x = 9. Paired with the map's last cells, those
  // points would pull the pose back towards x = 5.
  std::mt19937_64 rng(4);
  std::vector<Eigen::Vector2d> map_points, scan;
  addWall(&map_points, {0, 0}, {5, 0}, 0.01, 0.0, &rng);
  addWall(&map_points, {0, 2}, {5, 2}, 0.01, 0.0, &rng);
  addWall(&map_points, {0, 0}, {0, 2}, 0.01, 0.0, &rng);
  addWall(&scan, {0, 0}, {9, 0}, 0.05, 0.0, &rng);
  addWall(&scan, {0, 2}, {9, 2}, 0.05, 0.0, &rng);
  addWall(&scan, {0, 0}, {0, 2}, 0.05, 0.0, &rng);
  const PointMap map(map_points, 0.05, 0.2);
  const PointAlignment fit = alignToPoints(map, scan, Pose2(0.04, 0.0, 0.0), PointAlignmentOptions{});
  EXPECT_LT(fit.pose.translation().norm(), 0.002);
  EXPECT_LT(std::abs(fit.pose.theta()), 0.0005);
}

// Conditioning of the point-to-line information at the true pose: a bare corridor pins
// nothing along its axis once the normals' noise is discounted, a room pins both axes.
TEST(PointMap, ConditioningTellsABareCorridorFromARoom) {
  std::mt19937_64 rng(3);
  std::vector<Eigen::Vector2d> corridor;
  addWall(&corridor, {0, 0}, {20, 0}, 0.02, 0.01, &rng);
  addWall(&corridor, {0, 3}, {20, 3}, 0.02, 0.01, &rng);
  const PointMap corridor_map(corridor, 0.05, 0.2);
  std::vector<Eigen::Vector2d> seen;  // a scan's worth of the walls, in the map frame
  addWall(&seen, {5, 0}, {15, 0}, 0.05, 0.01, &rng);
  addWall(&seen, {5, 3}, {15, 3}, 0.05, 0.01, &rng);
  PointAlignmentOptions at_pose;
  at_pose.max_iterations = 0;
  const PointAlignment in_corridor = alignToPoints(corridor_map, seen, Pose2(), at_pose);
  const TranslationConditioning corridor_c =
      translationConditioning(withoutNormalNoise(in_corridor.information, 0.045));
  EXPECT_LT(corridor_c.ratio, 1e-3);
  EXPECT_GT(std::abs(corridor_c.weak_direction.x()), 0.99);  // along the corridor (x)
  // Without the discount the normals' tilt makes up some along-axis information.
  EXPECT_GT(translationConditioning(in_corridor.information).ratio, corridor_c.ratio);

  const std::vector<Eigen::Vector2d> room_points = room(0.01, 0.01, 4);
  const PointMap room_map(room_points, 0.05, 0.2);
  const PointAlignment in_room = alignToPoints(room_map, room(0.05, 0.01, 5), Pose2(), at_pose);
  const Eigen::Vector2d centre(4.0, 2.5);  // the room's middle, where the points are
  const TranslationConditioning room_c =
      translationConditioning(withoutNormalNoise(in_room.information, 0.045), -centre);
  // Walls of 2 x 8 m and 2 x 5 m (and the pillar): about 11/17 as much across x as across y.
  EXPECT_GT(room_c.ratio, 0.5);
  EXPECT_LT(room_c.ratio, 0.8);
  EXPECT_GT(std::abs(room_c.weak_direction.x()), 0.9);
  // About the frame origin, the room's own corner, the heading's lever arm costs x and y.
  EXPECT_LT(translationConditioning(withoutNormalNoise(in_room.information, 0.045)).ratio, room_c.ratio);
}

// The heading is marginalised: information coupling x to θ leaves less for x alone.
TEST(PointMap, ConditioningMarginalisesTheHeadingAboutTheGivenCentre) {
  Eigen::Matrix3d information;
  information << 4, 0, 2,  //
      0, 4, 0,             //
      2, 0, 2;
  const TranslationConditioning c = translationConditioning(information);
  // x's marginal information: 4 - 2·2/2 = 2; y's: 4.
  EXPECT_NEAR(c.ratio, 0.5, 1e-12);
  EXPECT_NEAR(c.strong, 4.0, 1e-12);
  EXPECT_NEAR(std::abs(c.weak_direction.x()), 1.0, 1e-12);
  EXPECT_EQ(translationConditioning(Eigen::Matrix3d::Zero()).ratio, 0.0);
  // Re-expressed about a centre c = (0, 1) (t − c = (0, −1)), it equals the information
  // built directly from residual Jacobians in those parameters: two line residuals of a
  // point at the pose's own origin, which a turn about c moves by δθ·(1, 0).
  const Eigen::Vector2d offset(0.0, -1.0);
  Eigen::Matrix<double, 2, 3> j;  // rows: residuals of x-normal and y-normal lines at (0, 0)
  j << 1, 0, 0,  //
      0, 1, 0;
  Eigen::Matrix<double, 2, 3> j_local;  // d r / d(δt_c, δθ)
  j_local << 1, 0, 1,  //
      0, 1, 0;
  const Eigen::Matrix3d info = j.transpose() * j + Eigen::Vector3d(0, 0, 1).asDiagonal().toDenseMatrix();
  const Eigen::Matrix3d info_local = j_local.transpose() * j_local + Eigen::Vector3d(0, 0, 1).asDiagonal().toDenseMatrix();
  EXPECT_NEAR(translationConditioning(info, offset).ratio, translationConditioning(info_local).ratio, 1e-12);
}

}  // namespace
}  // namespace storey::grid
