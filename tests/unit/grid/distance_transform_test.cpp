// Exactness of the distance transform on shapes the first tests do not cover: empty
// columns and rows, single lines, one source, and grids wide enough for 64-bit arithmetic.
#include "storey/grid/distance_transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace storey::grid {
namespace {

// Brute force over the (few) sources.
void expectExact(const GridFrame& f, const std::vector<std::uint8_t>& src) {
  std::vector<std::pair<int, int>> sources;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      if (src[f.index(x, y)]) sources.emplace_back(x, y);
  const Grid2<float> d2 = squaredDistanceTransform(f, src);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      double best = std::numeric_limits<double>::infinity();
      for (const auto& [sx, sy] : sources)
        best = std::min(best, double(sx - x) * (sx - x) + double(sy - y) * (sy - y));
      ASSERT_EQ(d2.at(x, y), static_cast<float>(best))
          << f.width << "x" << f.height << " at " << x << "," << y;
    }
}

GridFrame frame(int w, int h) {
  GridFrame f;
  f.width = w;
  f.height = h;
  return f;
}

TEST(DistanceTransformShapes, RandomDensitiesAndSizes) {
  std::mt19937_64 rng(21);
  for (int trial = 0; trial < 40; ++trial) {
    std::uniform_int_distribution<int> side(1, 60);
    const GridFrame f = frame(side(rng), side(rng));
    // From a single source to dense: empty columns and rows occur at low densities.
    std::bernoulli_distribution pick(std::pow(10.0, -3.0 + 3.0 * trial / 40.0));
    std::vector<std::uint8_t> src(f.cellCount(), 0);
    for (auto& s : src) s = pick(rng);
    src[std::uniform_int_distribution<std::size_t>(0, src.size() - 1)(rng)] = 1;
    expectExact(f, src);
  }
}

TEST(DistanceTransformShapes, SingleRowSingleColumnAndCorners) {
  for (const auto& [w, h] : {std::pair{1, 1}, {1, 50}, {50, 1}, {2, 2}, {7, 3}}) {
    const GridFrame f = frame(w, h);
    std::vector<std::uint8_t> src(f.cellCount(), 0);
    src[f.index(w - 1, h - 1)] = 1;  // far corner
    expectExact(f, src);
    src.assign(f.cellCount(), 0);
    src[0] = 1;
    expectExact(f, src);
  }
}

TEST(DistanceTransformShapes, WideGridUsesExactSixtyFourBitArithmetic) {
  // w + h > 26754 takes the 64-bit path; distances stay exact in float below 2^24.
  const GridFrame f = frame(30000, 2);
  std::vector<std::uint8_t> src(f.cellCount(), 0);
  src[f.index(0, 0)] = 1;
  src[f.index(4000, 1)] = 1;
  const Grid2<float> d2 = squaredDistanceTransform(f, src);
  EXPECT_EQ(d2.at(0, 1), 1.0f);
  EXPECT_EQ(d2.at(2000, 0), 2000.0f * 2000.0f);
  EXPECT_EQ(d2.at(2001, 1), 1999.0f * 1999.0f);
  EXPECT_EQ(d2.at(4000, 0), 1.0f);
  EXPECT_EQ(d2.at(4100, 1), 100.0f * 100.0f);
  // Beyond 2^24 float rounds; the value stays within float's relative precision.
  const double far = 25999.0 * 25999.0 + 1.0;
  EXPECT_NEAR(d2.at(29999, 0), far, far * 1e-7);
}

// Bounded at b cells, the transform is exact wherever the exact one is at most b² and above
// b² wherever the exact one is: what a field capped at b needs, computed from fewer columns.
TEST(DistanceTransformShapes, BoundedIsExactUpToItsBoundAndAboveItBeyond) {
  std::mt19937_64 rng(5);
  long beyond = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::uniform_int_distribution<int> side(1, 80);
    const GridFrame f = frame(side(rng), side(rng));
    std::bernoulli_distribution pick(std::pow(10.0, -3.5 + 3.0 * (trial % 20) / 20.0));
    std::vector<std::uint8_t> src(f.cellCount(), 0);
    for (auto& s : src) s = pick(rng);
    if (trial % 3 != 0) src[std::uniform_int_distribution<std::size_t>(0, src.size() - 1)(rng)] = 1;
    const int bound = std::uniform_int_distribution<int>(0, 25)(rng);
    const Grid2<float> exact = squaredDistanceTransform(f, src);
    const Grid2<float> bounded = squaredDistanceTransform(f, src, bound);
    const float b2 = static_cast<float>(bound) * bound;
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) {
        if (exact.at(x, y) <= b2) {
          ASSERT_EQ(bounded.at(x, y), exact.at(x, y))
              << f.width << "x" << f.height << " bound " << bound << " at " << x << "," << y;
        } else {
          ASSERT_GT(bounded.at(x, y), b2)
              << f.width << "x" << f.height << " bound " << bound << " at " << x << "," << y;
          ++beyond;
        }
      }
  }
  EXPECT_GT(beyond, 1000);  // the bound mattered in many cells
  // 64-bit path: the same on a grid 30000 cells wide.
  const GridFrame wide = frame(30000, 3);
  std::vector<std::uint8_t> src(wide.cellCount(), 0);
  src[wide.index(100, 0)] = 1;
  src[wide.index(20000, 2)] = 1;
  const Grid2<float> d2 = squaredDistanceTransform(wide, src, 10);
  EXPECT_EQ(d2.at(100, 2), 4.0f);
  EXPECT_EQ(d2.at(20006, 0), 40.0f);
  EXPECT_GT(d2.at(5000, 1), 100.0f);
}

TEST(DistanceTransformShapes, BoundedRowsWithNoSourceNearEnoughAreInfinite) {
  // The output grid is not filled before the transform: a row whose columns all have their
  // nearest source beyond the bound must be written as infinite by the transform itself. The
  // grid is built twice, first over memory left holding finite values by another grid.
  const GridFrame f = frame(40, 30);
  std::vector<std::uint8_t> src(f.cellCount(), 0);
  src[f.index(5, 2)] = 1;
  for (int pass = 0; pass < 2; ++pass) {
    { const Grid2<float> scratch(f, 7.0f); }
    const Grid2<float> d2 = squaredDistanceTransform(f, src, 3);
    EXPECT_EQ(d2.at(5, 2), 0.0f);
    EXPECT_EQ(d2.at(7, 4), 8.0f);
    for (int y = 6; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x)
        ASSERT_EQ(d2.at(x, y), std::numeric_limits<float>::infinity()) << x << "," << y;
  }
}

TEST(DistanceTransformShapes, NoSourceOrEmptyGrid) {
  const GridFrame f = frame(9, 4);
  const std::vector<std::uint8_t> none(f.cellCount(), 0);
  for (float v : squaredDistanceTransform(f, none).data) EXPECT_TRUE(std::isinf(v));
  EXPECT_TRUE(squaredDistanceTransform(frame(0, 0), {}).data.empty());
}

}  // namespace
}  // namespace storey::grid
