#include "storey/mapping/scan_matcher.h"

#include <gtest/gtest.h>

#include <random>

#include <Eigen/Eigenvalues>

#include "synthetic_world.h"
#include "test_support.h"

namespace storey::mapping {
namespace {

using geometry::Pose2;

MatchTarget targetFrom(const test::World& world, const std::vector<Pose2>& poses,
                       double resolution = 0.05, double growth_margin = 8.0) {
  grid::OccupancyGridOptions options;
  options.resolution = resolution;
  options.growth_margin = growth_margin;
  grid::OccupancyGrid grid(options);
  std::vector<sensor::LaserScan> scans;
  for (const auto& p : poses) scans.push_back(world.scan(p, 0.0));
  std::vector<grid::OccupancyGrid::PosedScan> posed;
  for (std::size_t i = 0; i < poses.size(); ++i) posed.push_back({&scans[i], poses[i]});
  grid.insertScans(posed);
  return MatchTarget(grid, grid::LikelihoodFieldOptions{}, 7);
}

// Poses every `step` metres along the x axis, heading along it.
std::vector<Pose2> posesAlongX(double from, double to, double step) {
  std::vector<Pose2> poses;
  for (double x = from; x <= to; x += step) poses.emplace_back(x, 0.0, 0.0);
  return poses;
}

TEST(ScanMatcher, PointResidualJacobianMatchesNumeric) {
  const test::World world = test::officeWorld();
  const MatchTarget target = targetFrom(world, {Pose2(4, 4, 0), Pose2(8, 3, 1.0)});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int k = 0; k < 500; ++k) {
    const Pose2 pose(4 + u(rng), 4 + u(rng), u(rng) * M_PI);
    const Eigen::Vector2d point(3 * u(rng), 3 * u(rng));
    Eigen::RowVector3d analytic;
    pointResidual(target.field(), pose, point, &analytic);
    auto f = [&](const Eigen::VectorXd& x) {
      Eigen::VectorXd r(1);
      r(0) = pointResidual(target.field(), Pose2(x(0), x(1), x(2)), point, nullptr);
      return r;
    };
    const Eigen::MatrixXd numeric = storey::test::numericJacobian(f, pose.vector(), 1e-7);
    // Bilinear interpolation has kinks at cell borders: skip the few evaluations straddling one.
    const Eigen::MatrixXd numeric_coarse = storey::test::numericJacobian(f, pose.vector(), 1e-6);
    if ((numeric - numeric_coarse).norm() > 1e-4 * (1 + numeric.norm())) continue;
    ++checked;
    EXPECT_NEAR((analytic.transpose() - numeric.transpose()).norm(), 0.0, 1e-4 * (1 + numeric.norm()))
        << "pose " << pose << " point " << point.transpose();
  }
  EXPECT_GT(checked, 400);
}

TEST(ScanMatcher, RecoversOffsetInRoom) {
  const test::World world = test::officeWorld();
  // A 2.5 cm grid: walls are quantised to half a cell, which bounds the absolute accuracy.
  const MatchTarget target =
      targetFrom(world, {Pose2(4, 4, 0), Pose2(8, 3, 1.0), Pose2(6, 6.5, -2.0)}, 0.025);
  ScanMatcher matcher;
  for (const Pose2 truth : {Pose2(6, 4, 0.3), Pose2(3.5, 6, -1.2), Pose2(10, 4, 2.5)}) {
    const auto points = filterPoints(world.scan(truth, 0.0).pointsInRobotFrame(), 0.05);
    const Pose2 prediction = truth * Pose2(0.2, -0.15, 0.1);
    const MatchResult r = matcher.match(target, points, prediction);
    ASSERT_TRUE(r.success) << r.problem;
    // Within 2 cm / 0.3°: the map's walls are quantised to 2.5 cm cells.
    EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.02) << r.pose << " vs " << truth;
    EXPECT_LT(std::abs(geometry::angleDiff(r.pose.theta(), truth.theta())), 0.3 * M_PI / 180);
    EXPECT_GT(r.score, 0.75);
    // A confident match: centimetre-level standard deviations.
    EXPECT_LT(std::sqrt(r.covariance(0, 0)), 0.05);
    EXPECT_LT(std::sqrt(r.covariance(1, 1)), 0.05);
  }
}

// Posts of 4 cm around the robot and no wall: the map's points keep no line-like cell (a
// post fills a cell or two, too few for a normal), so a point refinement has nothing to pair
// with, and the match says so instead of guessing.
TEST(ScanMatcher, AMapWithoutLinesGivesNoPointRefinement) {
  test::World world;
  for (int k = 0; k < 40; ++k) {
    const double a = 0.157 * k + 0.05 * (k % 3), r = 2.0 + 0.5 * (k % 5);
    const double x = 5 + r * std::cos(a), y = 4 + r * std::sin(a);
    world.addBox(x, y, x + 0.04, y + 0.04);
  }
  MatchTarget target = targetFrom(world, {Pose2(5, 4, 0), Pose2(5.3, 3.8, 1.5)});
  std::vector<Eigen::Vector2d> map_points;
  for (const Pose2& p : {Pose2(5, 4, 0), Pose2(5.3, 3.8, 1.5)})
    for (const auto& q : p.transformPoints(world.scan(p, 0.0).pointsInRobotFrame())) map_points.push_back(q);
  target.setPoints(grid::PointMap(map_points, 0.05, 0.2));
  int line_cells = 0;
  for (const auto& c : target.points().cells()) line_cells += !c.normal.isZero();
  EXPECT_LT(line_cells, 5) << "of " << target.points().size();

  const Pose2 truth(5.2, 4.1, 0.4);
  const auto points = world.scan(truth, 0.0).pointsInRobotFrame();
  ASSERT_GE(points.size(), 30u);
  const Pose2 prediction = truth * Pose2(0.1, -0.08, 0.05);
  ScanMatcherOptions o;
  o.point_refinement = true;
  o.min_points = 10;
  const MatchResult on_points = ScanMatcher(o).match(target, points, prediction);
  EXPECT_FALSE(on_points.success);
  EXPECT_LT(on_points.line_weight, 3.0);
  EXPECT_GE(on_points.line_weight, 0.0);
  // On the field the posts still place it.
  o.point_refinement = false;
  const MatchResult r = ScanMatcher(o).match(target, points, prediction);
  ASSERT_TRUE(r.success) << r.problem;
  EXPECT_EQ(r.line_weight, -1.0);  // refined on the field
  EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.05) << r.pose;
  EXPECT_LT(std::abs(geometry::angleDiff(r.pose.theta(), truth.theta())), 1.0 * M_PI / 180);
}

TEST(ScanMatcher, CorrelativeSearchIsExactOnTheGrid) {
  const test::World world = test::officeWorld();
  const MatchTarget target = targetFrom(world, {Pose2(4, 4, 0)});
  ScanMatcher matcher;
  const Pose2 truth(4, 4, 0);
  const auto points = world.scan(truth, 0.0).pointsInRobotFrame();
  // Offsets that are whole cells away: the correlative stage alone must land within a cell.
  const MatchResult r = matcher.correlativeSearch(target, points, Pose2(4.15, 3.9, 0.05), 0.3, 0.2);
  ASSERT_TRUE(r.success) << r.problem;
  EXPECT_LT((r.pose.translation() - truth.translation()).norm(), 0.05 * 1.5);
  EXPECT_LT(std::abs(r.pose.theta()), 0.01);
}

TEST(ScanMatcher, CorridorGivesWeakInformationAlongTheAxis) {
  const test::World world = test::corridorWorld();
  // The map covers more corridor than the scan sees, so no wall end gives information.
  // Many scans, as a robot driving along it would take (grazing beams erase wall cells).
  const MatchTarget target = targetFrom(world, posesAlongX(-15, 15, 0.5));
  ScanMatcher matcher;
  const Pose2 truth(0.5, 0.1, 0.05);
  const auto points = filterPoints(world.scan(truth, 0.0, 361, 10.0).pointsInRobotFrame(), 0.05);
  const Pose2 prediction(0.62, 0.0, 0.0);
  const MatchResult r = matcher.match(target, points, prediction);
  ASSERT_TRUE(r.success) << r.problem;
  // Across the corridor and in heading, the walls fix the pose...
  EXPECT_NEAR(r.pose.y(), truth.y(), 0.02);
  EXPECT_NEAR(r.pose.theta(), truth.theta(), 0.01);
  // ...along it nothing does: the match stays with the prediction rather than wandering...
  EXPECT_NEAR(r.pose.x(), prediction.x(), 0.06);
  // ...and says so: the along-axis standard deviation dwarfs the across one.
  const double sx = std::sqrt(r.covariance(0, 0)), sy = std::sqrt(r.covariance(1, 1));
  EXPECT_GT(sx, 1.0);
  EXPECT_LT(sy, 0.1);
  EXPECT_GT(sx / sy, 20.0);
}

TEST(ScanMatcher, BestElsewhereTellsRepeatingDoorsFromAUniquePlace) {
  // A corridor with a door recess every 3 m: a scan seeing 8 m fits nearly as well
  // elsewhere along it.
  test::World doors = test::corridorWorld();
  for (double x = -30; x <= 30; x += 3.0) doors.addBox(x, 1.0, x + 0.9, 1.4);
  const MatchTarget corridor = targetFrom(doors, posesAlongX(-20, 20, 0.5));
  ScanMatcher matcher;
  const Pose2 truth(0.3, 0.1, 0.02);
  const auto corridor_points = filterPoints(doors.scan(truth, 0.0, 361, 8.0).pointsInRobotFrame(), 0.05);
  const MatchResult best = matcher.correlativeSearch(corridor, corridor_points, truth, 4.0, 0.2);
  ASSERT_TRUE(best.success) << best.problem;
  EXPECT_NEAR(best.pose.y(), truth.y(), 0.05);
  EXPECT_LT((best.pose.translation() - truth.translation()).norm(), 0.25);
  const MatchResult other =
      matcher.bestElsewhere(corridor, corridor_points, truth, 4.0, 0.2, best.pose.translation(), 1.0);
  ASSERT_TRUE(other.success) << other.problem;
  EXPECT_GT((other.pose.translation() - best.pose.translation()).norm(), 1.0);  // left out
  EXPECT_NEAR(other.pose.y(), best.pose.y(), 0.1);  // along the corridor
  EXPECT_GT(other.correlative_score, 0.9 * best.correlative_score);
  // Asked only for places scoring above the best, there is none.
  EXPECT_FALSE(matcher.bestElsewhere(corridor, corridor_points, truth, 4.0, 0.2, best.pose.translation(), 1.0,
                                     best.correlative_score)
                   .success);

  // The office: nothing more than 1 m away fits nearly as well.
  const test::World office = test::officeWorld();
  const MatchTarget room = targetFrom(office, {Pose2(4, 4, 0), Pose2(8, 3, 1.0), Pose2(6, 6.5, -2.0)});
  const Pose2 at(6, 4, 0.3);
  const auto room_points = filterPoints(office.scan(at, 0.0).pointsInRobotFrame(), 0.05);
  const MatchResult unique = matcher.correlativeSearch(room, room_points, at, 4.0, 0.2);
  ASSERT_TRUE(unique.success) << unique.problem;
  const MatchResult elsewhere =
      matcher.bestElsewhere(room, room_points, at, 4.0, 0.2, unique.pose.translation(), 1.0);
  if (elsewhere.success) {
    EXPECT_GT((elsewhere.pose.translation() - unique.pose.translation()).norm(), 1.0);
    EXPECT_LT(elsewhere.correlative_score, 0.9 * unique.correlative_score);
  }
}

TEST(ScanMatcher, ASearchStopsAtItsLookupBudgetAndSaysSo) {
  const test::World world = test::officeWorld();
  const MatchTarget target = targetFrom(world, {Pose2(4, 4, 0), Pose2(8, 3, 1.0)});
  const Pose2 truth(4, 4, 0);
  const auto points = filterPoints(world.scan(truth, 0.0).pointsInRobotFrame(), 0.05);
  ScanMatcherOptions options;
  const MatchResult full =
      ScanMatcher(options).correlativeSearch(target, points, Pose2(4.4, 3.7, 0.1), 2.0, 0.3);
  ASSERT_TRUE(full.success) << full.problem;
  EXPECT_FALSE(full.exhausted);
  const double lookups =
      static_cast<double>(full.candidates_scored) * static_cast<double>(points.size());
  // A budget the full search needed: found as before.
  options.max_lookups = lookups;
  const MatchResult enough =
      ScanMatcher(options).correlativeSearch(target, points, Pose2(4.4, 3.7, 0.1), 2.0, 0.3);
  ASSERT_TRUE(enough.success) << enough.problem;
  EXPECT_EQ(enough.pose.translation(), full.pose.translation());
  // A tenth of it: the search stops within its budget, with no match and no claim.
  options.max_lookups = 0.1 * lookups;
  const ScanMatcher bounded(options);
  const MatchResult cut = bounded.correlativeSearch(target, points, Pose2(4.4, 3.7, 0.1), 2.0, 0.3);
  EXPECT_FALSE(cut.success);
  EXPECT_TRUE(cut.exhausted);
  EXPECT_LE(static_cast<double>(cut.candidates_scored) * static_cast<double>(points.size()),
            0.1 * lookups);
  const MatchResult rival = bounded.bestElsewhere(target, points, Pose2(4.4, 3.7, 0.1), 2.0, 0.3,
                                                  full.pose.translation(), 0.5);
  EXPECT_FALSE(rival.success);
  EXPECT_TRUE(rival.exhausted);  // not "there is none": it did not look everywhere
}

TEST(ScanMatcher, FailsCleanlyWithoutMapOrPoints) {
  ScanMatcher matcher;
  const MatchTarget empty;
  std::vector<Eigen::Vector2d> points(50, Eigen::Vector2d(1, 0));
  EXPECT_FALSE(matcher.match(empty, points, Pose2()).success);
  const test::World world = test::officeWorld();
  const MatchTarget target = targetFrom(world, {Pose2(4, 4, 0)});
  const MatchResult r = matcher.match(target, {}, Pose2(4, 4, 0));
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.problem.find("too few points"), std::string::npos);
}

TEST(ScanMatcher, FilterPointsKeepsOnePerNeighbourhood) {
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < 100; ++i) points.emplace_back(i * 0.01, 0.0);  // 1 m at 1 cm spacing
  const auto kept = filterPoints(points, 0.05);
  // Every 5th or 6th point (1 cm steps are not exact in floating point).
  EXPECT_GE(kept.size(), 16u);
  EXPECT_LE(kept.size(), 20u);
  for (std::size_t i = 1; i < kept.size(); ++i) EXPECT_GE((kept[i] - kept[i - 1]).norm(), 0.05 - 1e-12);
  EXPECT_EQ(filterPoints(points, 0.0).size(), points.size());
}

}  // namespace
}  // namespace storey::mapping

namespace storey::mapping {
namespace {

TEST(MatchTarget, PyramidEqualsGridMaxPyramid) {
  const test::World world = test::officeWorld();
  grid::OccupancyGrid grid;
  grid.insertScan(world.scan(geometry::Pose2(4, 4, 0.2), 0.0), geometry::Pose2(4, 4, 0.2));
  const MatchTarget target(grid, grid::LikelihoodFieldOptions{}, 6);
  const auto reference = grid::maxPyramid(target.field().score(), 6);
  ASSERT_EQ(static_cast<std::size_t>(target.pyramidLevels()), reference.size());
  for (std::size_t k = 0; k < reference.size(); ++k)
    EXPECT_EQ(target.pyramidLevel(static_cast<int>(k)).data, reference[k].data) << k;
}

// Point-to-line information of points on lines with these normals, seen from the origin.
Eigen::Matrix3d lineInformation(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& points_normals) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (const auto& [p, n] : points_normals) {
    const Eigen::RowVector3d j(n.x(), n.y(), n.x() * -p.y() + n.y() * p.x());
    h += j.transpose() * j;
  }
  return h;
}

TEST(MatchTarget, AGridEndingWhereTheSearchStopsLookingMatchesLikeARoomyOne) {
  // A wide search's coarsest blocks (64 cells) start up to 3.2 m outside the returns; the
  // grid must reach that far plus the field's cap, or a block outside reads 0 and hides the
  // walls it covers (FloorSlam's targets are this tight).
  const test::World world = test::officeWorld();
  const std::vector<Pose2> poses = {Pose2(2, 2, 0), Pose2(4, 4, 0), Pose2(8, 3, 1.0)};
  const double tight_margin = grid::LikelihoodFieldOptions{}.max_distance + (64 + 1) * 0.05;
  const MatchTarget roomy = targetFrom(world, poses, 0.05, 8.0);
  const MatchTarget tight = targetFrom(world, poses, 0.05, tight_margin);
  ASSERT_LT(tight.field().frame().cellCount(), roomy.field().frame().cellCount() * 3 / 5);
  ScanMatcher matcher;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> offset(-1.5, 1.5), turn(-0.4, 0.4);
  for (const Pose2 truth : {Pose2(2.5, 2, 0.3), Pose2(4, 4.5, -1.2), Pose2(7.5, 3, 2.5), Pose2(1.2, 1.2, 0.8)}) {
    const auto points = filterPoints(world.scan(truth, 0.0).pointsInRobotFrame(), 0.05);
    const Pose2 prediction = truth * Pose2(offset(rng), offset(rng), turn(rng));
    const MatchResult a = matcher.correlativeSearch(roomy, points, prediction, 2.0, 0.5);
    const MatchResult b = matcher.correlativeSearch(tight, points, prediction, 2.0, 0.5);
    ASSERT_TRUE(a.success) << a.problem;
    ASSERT_TRUE(b.success) << b.problem;
    EXPECT_LT((a.pose.translation() - b.pose.translation()).norm(), 1e-9) << a.pose << " vs " << b.pose;
    EXPECT_LT(std::abs(a.pose.theta() - b.pose.theta()), 1e-12);
    // Not to the last bit: the two grids' origins are different multiples of the cell size
    // in floating point, so a return exactly on a cell border (the simulated walls) can
    // fall in the neighbouring cell.
    EXPECT_NEAR(a.correlative_score, b.correlative_score, 0.005);
  }
}

TEST(NormalNoise, ACorridorsTiltedNormalsGiveNoInformationAlongIt) {
  // Two walls along x at y = ±1, normals tilted ±1° at random: the sliver of x
  // information is the tilt's, not the corridor's.
  std::mt19937 rng(3);
  std::normal_distribution<double> tilt(0.0, 0.0175);
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> corridor;
  for (int i = -100; i <= 100; ++i)
    for (double y : {-1.0, 1.0}) {
      const double a = tilt(rng);
      corridor.push_back({{0.1 * i, y}, {std::sin(a), std::cos(a)}});
    }
  const Eigen::Matrix3d h = lineInformation(corridor);
  ASSERT_GT(h(0, 0), 0.01);  // the phantom
  const Eigen::Matrix3d cleaned = grid::withoutNormalNoise(h, 0.045);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(cleaned.topLeftCorner<2, 2>());
  EXPECT_NEAR(eigen.eigenvalues()(0), 0.0, 1e-9 * h(1, 1));
  EXPECT_NEAR(cleaned(1, 1), h(1, 1), 1e-3 * h(1, 1));  // across the corridor: kept
  EXPECT_NEAR(cleaned(2, 2), h(2, 2), 0.01 * h(2, 2));
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cleaned).eigenvalues()(0), -1e-9 * h(1, 1));

  // The same corridor with a door frame (10 points facing along it): kept, less the
  // tilt's share.
  auto with_door = corridor;
  for (int i = 0; i < 10; ++i) with_door.push_back({{3.0, -0.5 + 0.1 * i}, {1.0, 0.0}});
  const Eigen::Matrix3d hd = lineInformation(with_door);
  const Eigen::Matrix3d cd = grid::withoutNormalNoise(hd, 0.045);
  EXPECT_GT(cd(0, 0), 0.9 * hd(0, 0));
  EXPECT_LT(cd(0, 0), hd(0, 0));
  EXPECT_EQ(grid::withoutNormalNoise(hd, 0.0), hd);
}

}  // namespace
}  // namespace storey::mapping
