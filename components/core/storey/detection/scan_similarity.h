// A cheap similarity between two laser scans taken from (nearly) the same pose: inside an
// elevator cabin the walls move with the robot, so consecutive scans barely change while
// the height does.
#pragma once

#include "storey/sensor/laser_scan.h"

namespace storey::detection {

struct ScanSimilarityOptions {
  double absolute_tolerance = 0.05;  // m
  double relative_tolerance = 0.03;  // of the range
};

// Fraction in [0, 1] of beams that agree: both returns within tolerance, or both no
// return. Returns a negative value when the scans cannot be compared (different beam
// layouts, or no beam with a return in either).
double scanSimilarity(const sensor::LaserScan& a, const sensor::LaserScan& b,
                      const ScanSimilarityOptions& options = {});

}  // namespace storey::detection
