#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "storey/grid/distance_transform.h"
#include "storey/grid/image.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "test_support.h"

namespace storey::grid {
namespace {

sensor::LaserScan ringScan(int beams, float range) {
  sensor::LaserScan scan;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / beams;
  scan.range_min = 0.05;
  scan.range_max = 20.0;
  scan.ranges.assign(beams, range);
  return scan;
}

TEST(DistanceTransform, MatchesBruteForce) {
  std::mt19937_64 rng(7);
  GridFrame f;
  f.width = 37;
  f.height = 23;
  f.resolution = 0.1;
  std::vector<std::uint8_t> src(f.cellCount(), 0);
  std::bernoulli_distribution pick(0.03);
  for (auto& s : src) s = pick(rng);
  const Grid2<float> d2 = squaredDistanceTransform(f, src);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      double best = std::numeric_limits<double>::infinity();
      for (int sy = 0; sy < f.height; ++sy)
        for (int sx = 0; sx < f.width; ++sx)
          if (src[f.index(sx, sy)]) best = std::min(best, double((sx - x) * (sx - x) + (sy - y) * (sy - y)));
      EXPECT_FLOAT_EQ(d2.at(x, y), best) << x << "," << y;
    }
}

TEST(DistanceTransform, NoSourceIsInfiniteAndCapped) {
  GridFrame f;
  f.width = 5;
  f.height = 4;
  std::vector<std::uint8_t> src(f.cellCount(), 0);
  EXPECT_TRUE(std::isinf(squaredDistanceTransform(f, src).at(2, 2)));
  EXPECT_FLOAT_EQ(distanceField(f, src, 1.5).at(2, 2), 1.5f);
}

TEST(OccupancyGrid, RingScanMarksWallAndFreeInside) {
  OccupancyGridOptions options;
  options.resolution = 0.05;
  OccupancyGrid grid(options);
  // Each scan updates a cell once: four misses make a cell free at the default log-odds.
  for (int i = 0; i < 5; ++i) grid.insertScan(ringScan(720, 3.0f), geometry::Pose2(1.0, 2.0, 0.3));
  const GridFrame& f = grid.frame();
  const Eigen::Vector2i center = f.cellOf({1.0, 2.0});
  EXPECT_EQ(grid.stateAt(center.x(), center.y()), CellState::kFree);
  const double beam = ringScan(720, 3.0f).angle(400) + 0.3;
  const Eigen::Vector2i wall = f.cellOf({1.0 + 3.0 * std::cos(beam), 2.0 + 3.0 * std::sin(beam)});
  EXPECT_EQ(grid.stateAt(wall.x(), wall.y()), CellState::kOccupied);
  const Eigen::Vector2i outside = f.cellOf({1.0 + 3.5, 2.0});
  EXPECT_EQ(grid.stateAt(outside.x(), outside.y()), CellState::kUnknown);
}

TEST(OccupancyGrid, GrowsWithoutMovingExistingCells) {
  OccupancyGrid grid;
  grid.insertScan(ringScan(360, 2.0f), geometry::Pose2(0, 0, 0));
  const Eigen::Vector2d probe(2.0, 0.0);
  const Eigen::Vector2i before = grid.frame().cellOf(probe);
  const float value = grid.logOddsAt(before.x(), before.y());
  ASSERT_GT(value, 0.0f);
  grid.insertScan(ringScan(360, 2.0f), geometry::Pose2(-40, 30, 0));
  const Eigen::Vector2i after = grid.frame().cellOf(probe);
  EXPECT_FLOAT_EQ(grid.logOddsAt(after.x(), after.y()), value);
  EXPECT_LT(grid.frame().origin_x, -40.0);
}

TEST(OccupancyGrid, InvalidReturnsAreNotObstacles) {
  OccupancyGrid grid;
  sensor::LaserScan scan = ringScan(100, std::numeric_limits<float>::quiet_NaN());
  scan.ranges[0] = 20.0f;  // at range_max: nothing seen
  grid.insertScan(scan, geometry::Pose2());
  EXPECT_TRUE(grid.empty());
  OccupancyGridOptions options;
  options.free_space_for_no_return = true;
  options.no_return_free_range = 5.0;
  OccupancyGrid with_free(options);
  scan.ranges[1] = std::numeric_limits<float>::infinity();  // ROS: no return within range
  for (int i = 0; i < 5; ++i) with_free.insertScan(scan, geometry::Pose2());
  ASSERT_FALSE(with_free.empty());
  EXPECT_EQ(with_free.countStates()[static_cast<int>(CellState::kOccupied)], 0u);
  EXPECT_GT(with_free.countStates()[static_cast<int>(CellState::kFree)], 0u);
}

TEST(OccupancyGrid, MapServerFilesRoundTrip) {
  OccupancyGrid grid;
  grid.insertScan(ringScan(360, 2.0f), geometry::Pose2(0.5, 0.5, 0));
  const std::string dir = test::makeTempDir();
  writeMapServerFiles(grid, dir + "/floor0");
  std::ifstream pgm(dir + "/floor0.pgm", std::ios::binary);
  std::string magic, comment;
  int w, h, maxval;
  pgm >> magic;
  pgm.ignore();
  std::getline(pgm, comment);
  pgm >> w >> h >> maxval;
  pgm.ignore();
  EXPECT_EQ(magic, "P5");
  EXPECT_EQ(w, grid.frame().width);
  EXPECT_EQ(h, grid.frame().height);
  std::vector<char> pixels(static_cast<std::size_t>(w) * h);
  pgm.read(pixels.data(), static_cast<std::streamsize>(pixels.size()));
  EXPECT_TRUE(pgm.good());
  const Eigen::Vector2i wall = grid.frame().cellOf({2.5, 0.5});
  EXPECT_EQ(static_cast<unsigned char>(pixels[(h - 1 - wall.y()) * w + wall.x()]), 0);
  std::ifstream yaml(dir + "/floor0.yaml");
  std::string text((std::istreambuf_iterator<char>(yaml)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("image: floor0.pgm"), std::string::npos);
  EXPECT_NE(text.find("resolution: 0.05"), std::string::npos);
}

TEST(Image, PngRoundTrip) {
  Image image(13, 7, 3);
  for (std::size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] = static_cast<std::uint8_t>(i * 31);
  const std::string path = test::makeTempDir() + "/x.png";
  writePng(path, image);
  const Image back = readPng(path);
  EXPECT_EQ(back.width, 13);
  EXPECT_EQ(back.channels, 3);
  EXPECT_EQ(back.pixels, image.pixels);
  EXPECT_THROW(readPng("/nonexistent.png"), std::runtime_error);
}

TEST(LikelihoodField, ValuesAndGradientMatchNumeric) {
  GridFrame f;
  f.width = 60;
  f.height = 60;
  f.resolution = 0.05;
  std::vector<std::uint8_t> obstacles(f.cellCount(), 0);
  for (int y = 0; y < f.height; ++y) obstacles[f.index(30, y)] = 1;  // a wall at x = 1.525
  LikelihoodFieldOptions options;
  options.sigma_hit = 0.2;
  LikelihoodField field(f, obstacles, options);
  EXPECT_FLOAT_EQ(field.distance().at(30, 10), 0.0f);
  EXPECT_NEAR(field.distance().at(34, 10), 0.2, 1e-6);
  EXPECT_GT(field.logLikelihoodAt({1.52, 1.0}), field.logLikelihoodAt({1.9, 1.0}));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.6, 2.4);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector2d p(u(rng), u(rng));
    Eigen::Vector2d g;
    field.interpolatedScore(p, &g);
    auto fn = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      return Eigen::VectorXd::Constant(1, field.interpolatedScore(Eigen::Vector2d(v.x(), v.y())));
    };
    const Eigen::MatrixXd numeric = test::numericJacobian(fn, p, 1e-7);
    // Bilinear interpolation is only piecewise smooth: skip points on a cell border.
    const Eigen::Vector2d c = f.continuousCellOf(p) - Eigen::Vector2d(0.5, 0.5);
    if (std::abs(c.x() - std::round(c.x())) < 1e-3 || std::abs(c.y() - std::round(c.y())) < 1e-3) continue;
    EXPECT_NEAR(g.x(), numeric(0, 0), 1e-4);
    EXPECT_NEAR(g.y(), numeric(0, 1), 1e-4);
  }
}

TEST(MaxPyramid, MatchesBruteForce) {
  GridFrame f;
  f.width = 19;
  f.height = 11;
  Grid2<float> base(f, 0.0f);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> u(0, 1);
  for (auto& v : base.data) v = u(rng);
  const auto pyramid = maxPyramid(base, 4);
  ASSERT_EQ(pyramid.size(), 4u);
  for (int level = 0; level < 4; ++level) {
    const int w = 1 << level;
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        float best = 0;
        for (int dy = 0; dy < w; ++dy)
          for (int dx = 0; dx < w; ++dx)
            if (f.contains(x + dx, y + dy)) best = std::max(best, base.at(x + dx, y + dy));
        EXPECT_FLOAT_EQ(pyramid[level].at(x, y), best);
      }
  }
}

}  // namespace
}  // namespace storey::grid
