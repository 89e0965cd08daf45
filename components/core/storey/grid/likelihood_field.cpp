#include "storey/grid/likelihood_field.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <stdexcept>

#include "storey/grid/distance_transform.h"

namespace storey::grid {

std::vector<std::uint8_t> obstacleMask(const OccupancyGrid& grid, double occupied_threshold) {
  const GridFrame& f = grid.frame();
  // p > threshold exactly where the log-odds exceed logit(threshold): a comparison per
  // cell instead of an exp. An unobserved cell (log-odds exactly 0) is never occupied.
  const float logit = static_cast<float>(std::log(occupied_threshold / (1.0 - occupied_threshold)));
  const auto& log_odds = grid.logOdds().data;
  std::vector<std::uint8_t> mask(f.cellCount(), 0);
  if (logit >= 0.0f) {
    // Above a non-negative logit is never exactly 0: one comparison, which vectorises.
    for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = log_odds[i] > logit;
  } else {
    for (std::size_t i = 0; i < mask.size(); ++i)
      mask[i] = log_odds[i] != 0.0f && log_odds[i] > logit;
  }
  return mask;
}

LikelihoodField::LikelihoodField(const OccupancyGrid& grid, const LikelihoodFieldOptions& options,
                                 LogLikelihoodTable table)
    : options_(options) {
  distance_.frame = grid.frame();
  build(obstacleMask(grid, options.occupied_threshold), table);
}

LikelihoodField::LikelihoodField(const GridFrame& frame, const std::vector<std::uint8_t>& obstacles,
                                 const LikelihoodFieldOptions& options, LogLikelihoodTable table)
    : options_(options) {
  distance_.frame = frame;
  build(obstacles, table);
}

void LikelihoodField::build(const std::vector<std::uint8_t>& obstacles, LogLikelihoodTable log_table) {
  const GridFrame frame = distance_.frame;
  const double norm = 1.0 / (std::sqrt(2.0 * M_PI) * options_.sigma_hit);
  const double inv_two_sigma2 = 1.0 / (2.0 * options_.sigma_hit * options_.sigma_hit);
  const double uniform = options_.z_rand / options_.range_max;
  const float res = static_cast<float>(frame.resolution),
              cap = static_cast<float>(options_.max_distance);
  // Squared distances in cells are integers, and every one beyond the cap gives the same
  // values: tabulate distance, log-likelihood and score per squared distance up to the cap
  // instead of evaluating sqrt, exp and log per cell (same expressions, same results).
  struct Entry {
    float distance, log_likelihood, score;
  };
  auto entry = [&](float squared) {
    const float d = std::min(std::sqrt(squared) * res, cap);
    const double dd = d;
    const double gauss = std::exp(-dd * dd * inv_two_sigma2);
    return Entry{d, static_cast<float>(std::log(options_.z_hit * norm * gauss + uniform)),
                 static_cast<float>(gauss)};
  };
  const double cap_cells = options_.max_distance / frame.resolution;
  std::size_t table_size = static_cast<std::size_t>(std::ceil(cap_cells * cap_cells)) + 1;
  // Float sqrt and product are monotonic: once one squared distance reaches the cap, every
  // larger one does. Grow the table until the first entry past it is at the cap.
  while (entry(static_cast<float>(table_size)).distance < cap) ++table_size;
  constexpr std::size_t kMaxTable = std::size_t{1} << 22;  // huge caps: evaluate per cell
  const bool tabulate = table_size <= kMaxTable;
  std::vector<Entry> table(tabulate ? table_size : 0);
  for (std::size_t k = 0; k < table.size(); ++k) table[k] = entry(static_cast<float>(k));
  const Entry beyond = entry(std::numeric_limits<float>::infinity());

  // The squared distances are overwritten by the distances in place (one grid less). Every
  // squared distance from table_size on maps to `beyond`, so the transform need only be
  // exact up to there: bounded at ceil(sqrt(table_size)) cells, it skips the columns with
  // no obstacle that close to the row, and what it returns above that bound is above
  // table_size too.
  const int exact_up_to =
      tabulate ? static_cast<int>(std::ceil(std::sqrt(static_cast<double>(table_size)))) : -1;
  distance_ = squaredDistanceTransform(frame, obstacles, exact_up_to);
  // Both written cell by cell below.
  score_ = Grid2<float>(frame, Unfilled{});
  const bool with_log = log_table == LogLikelihoodTable::kBuild;
  log_likelihood_ = with_log ? Grid2<float>(frame, Unfilled{}) : Grid2<float>();
  float* distance = distance_.data.data();
  float* score = score_.data.data();
  float* log_likelihood = with_log ? log_likelihood_.data.data() : nullptr;
  for (std::size_t i = 0; i < distance_.data.size(); ++i) {
    const float k = distance[i];
    const Entry e = !tabulate                            ? entry(k)
                    : k < static_cast<float>(table_size) ? table[static_cast<std::size_t>(k)]
                                                         : beyond;
    distance[i] = e.distance;
    score[i] = e.score;
    if (log_likelihood) log_likelihood[i] = e.log_likelihood;
  }
  const double d = options_.max_distance;
  outside_log_likelihood_ =
      static_cast<float>(std::log(options_.z_hit * norm * std::exp(-d * d * inv_two_sigma2) + uniform));
}

float LikelihoodField::logLikelihoodAt(const Eigen::Vector2d& p) const {
  const Eigen::Vector2i c = frame().cellOf(p);
  if (log_likelihood_.data.size() != frame().cellCount())
    throw std::logic_error("likelihood field: built without its log-likelihood table");
  return log_likelihood_.valueOr(c.x(), c.y(), outside_log_likelihood_);
}

double LikelihoodField::interpolatedScore(const Eigen::Vector2d& p, Eigen::Vector2d* gradient) const {
  const GridFrame& f = frame();
  // Cell centres sit at integer + 0.5 in continuous cell coordinates.
  const Eigen::Vector2d c = f.continuousCellOf(p) - Eigen::Vector2d(0.5, 0.5);
  const int x0 = floorToInt(c.x()), y0 = floorToInt(c.y());
  const double fx = c.x() - x0, fy = c.y() - y0;
  const double v00 = score_.valueOr(x0, y0, 0.0f), v10 = score_.valueOr(x0 + 1, y0, 0.0f);
  const double v01 = score_.valueOr(x0, y0 + 1, 0.0f), v11 = score_.valueOr(x0 + 1, y0 + 1, 0.0f);
  if (gradient) {
    const double inv_res = 1.0 / f.resolution;
    gradient->x() = ((v10 - v00) * (1 - fy) + (v11 - v01) * fy) * inv_res;
    gradient->y() = ((v01 - v00) * (1 - fx) + (v11 - v10) * fx) * inv_res;
  }
  return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy;
}

namespace {
// out[i] = max(in[i .. i + window)) along one line (shorter window at the far end).
void slidingMax(const float* in, float* out, int n, int stride, int window) {
  std::deque<int> candidates;  // indices with decreasing values
  for (int i = n - 1; i >= 0; --i) {
    while (!candidates.empty() && in[candidates.back() * stride] <= in[i * stride]) candidates.pop_back();
    candidates.push_back(i);
    while (candidates.front() >= i + window) candidates.pop_front();
    out[i * stride] = in[candidates.front() * stride];
  }
}
}  // namespace

std::vector<Grid2<float>> maxPyramid(const Grid2<float>& base, int levels) {
  std::vector<Grid2<float>> pyramid{base};
  const GridFrame& f = base.frame;
  for (int level = 1; level < levels; ++level) {
    const int window = 1 << level;
    Grid2<float> rows(f, 0.0f), out(f, 0.0f);
    for (int y = 0; y < f.height; ++y)
      slidingMax(&base.data[f.index(0, y)], &rows.data[f.index(0, y)], f.width, 1, window);
    for (int x = 0; x < f.width; ++x)
      slidingMax(&rows.data[f.index(x, 0)], &out.data[f.index(x, 0)], f.height, f.width, window);
    pyramid.push_back(std::move(out));
  }
  return pyramid;
}

}  // namespace storey::grid
