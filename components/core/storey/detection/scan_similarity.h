// A cheap similarity between two laser scans taken from (nearly) the same pose: inside an
// elevator cabin the walls move with the robot, so consecutive scans barely change while
// the height does.
#pragma once

#include "storey/common/shipped_config.h"
#include "storey/sensor/laser_scan.h"

namespace storey::detection {

// The shipped file's detector values (config/floor_detector.yaml), the defaults below.
namespace shipped_detector = shipped::floor_detector::detector;

struct ScanSimilarityOptions {
  // m
  double absolute_tolerance = shipped_detector::corroboration::scan_absolute_tolerance;
  // of the range
  double relative_tolerance = shipped_detector::corroboration::scan_relative_tolerance;
};

// Fraction in [0, 1] of beams that agree: both returns within tolerance, or both no
// return. Returns a negative value when the scans cannot be compared (different beam
// layouts, or no beam with a return in either).
double scanSimilarity(const sensor::LaserScan& a, const sensor::LaserScan& b,
                      const ScanSimilarityOptions& options = {});

}  // namespace storey::detection
