#include "storey/detection/scan_similarity.h"

#include <algorithm>
#include <cmath>

namespace storey::detection {

double scanSimilarity(const sensor::LaserScan& a, const sensor::LaserScan& b,
                      const ScanSimilarityOptions& options) {
  if (a.size() != b.size() || a.size() == 0) return -1.0;
  if (std::abs(a.angle_min - b.angle_min) > 1e-6 ||
      std::abs(a.angle_increment - b.angle_increment) > 1e-9) {
    return -1.0;
  }
  std::size_t agree = 0;
  std::size_t considered = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const bool ra = a.isReturn(i);
    const bool rb = b.isReturn(i);
    if (!ra && !rb) continue;  // both open: says nothing about the walls
    ++considered;
    if (ra && rb) {
      const double r = std::min(a.ranges[i], b.ranges[i]);
      const double tolerance = options.absolute_tolerance + options.relative_tolerance * r;
      if (std::abs(static_cast<double>(a.ranges[i]) - b.ranges[i]) <= tolerance) ++agree;
    }
  }
  if (considered == 0) return -1.0;
  return static_cast<double>(agree) / static_cast<double>(considered);
}

}  // namespace storey::detection
