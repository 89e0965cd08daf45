// The likelihood field's tables give exactly what the per-cell formulas give.
#include "storey/grid/likelihood_field.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "storey/grid/distance_transform.h"

namespace storey::grid {
namespace {

void expectMatchesFormula(double resolution, double max_distance, double obstacle_density) {
  GridFrame f;
  f.width = 83;
  f.height = 61;
  f.resolution = resolution;
  std::mt19937_64 rng(5);
  std::bernoulli_distribution pick(obstacle_density);
  std::vector<std::uint8_t> obstacles(f.cellCount(), 0);
  for (auto& o : obstacles) o = pick(rng);
  LikelihoodFieldOptions options;
  options.sigma_hit = 0.15;
  options.max_distance = max_distance;
  const LikelihoodField field(f, obstacles, options);
  const Grid2<float> distance = distanceField(f, obstacles, max_distance);
  const double norm = 1.0 / (std::sqrt(2.0 * M_PI) * options.sigma_hit);
  for (std::size_t i = 0; i < f.cellCount(); ++i) {
    ASSERT_EQ(field.distance().data[i], distance.data[i]) << i;
    const double d = distance.data[i];
    const double gauss = std::exp(-d * d / (2.0 * options.sigma_hit * options.sigma_hit));
    ASSERT_EQ(field.score().data[i], static_cast<float>(gauss)) << i;
    ASSERT_EQ(field.logLikelihood().data[i],
              static_cast<float>(
                  std::log(options.z_hit * norm * gauss + options.z_rand / options.range_max)))
        << i;
  }
}

TEST(LikelihoodFieldTables, MatchThePerCellFormulas) {
  expectMatchesFormula(0.05, 1.0, 0.01);   // capped: many cells beyond the table
  expectMatchesFormula(0.05, 0.37, 0.2);   // a cap between cells
  expectMatchesFormula(0.1, 50.0, 0.002);  // nothing reaches the cap
  expectMatchesFormula(0.01, 30.0, 0.01);  // a cap too large to tabulate: per-cell path
  expectMatchesFormula(0.05, 1.0, 0.0);    // no obstacle: every cell at the cap
}

TEST(LikelihoodFieldTables, SkippingTheLogLikelihoodLeavesDistanceAndScoreAsTheyWere) {
  GridFrame f;
  f.width = 47;
  f.height = 39;
  std::mt19937_64 rng(9);
  std::bernoulli_distribution pick(0.03);
  std::vector<std::uint8_t> obstacles(f.cellCount(), 0);
  for (auto& o : obstacles) o = pick(rng);
  const LikelihoodFieldOptions options;
  const LikelihoodField all(f, obstacles, options);
  const LikelihoodField lean(f, obstacles, options, LikelihoodField::LogLikelihoodTable::kSkip);
  EXPECT_EQ(lean.distance().data, all.distance().data);
  EXPECT_EQ(lean.score().data, all.score().data);
  EXPECT_TRUE(lean.logLikelihood().data.empty());
  EXPECT_THROW(lean.logLikelihoodAt({0.5, 0.5}), std::logic_error);
  EXPECT_NO_THROW(all.logLikelihoodAt({0.5, 0.5}));
}

}  // namespace
}  // namespace storey::grid
