// Shared by the matching unit tests: pose errors and the matcher's test options.
#pragma once

#include <cmath>

#include "storey/geometry/pose2.h"
#include "storey/matching/floor_matcher.h"

namespace storey::matching::test {

using geometry::Pose2;

inline double angleError(const Pose2& a, const Pose2& b) {
  return std::abs(geometry::angleDiff(a.theta(), b.theta()));
}
inline double translationError(const Pose2& a, const Pose2& b) {
  return (a.translation() - b.translation()).norm();
}

inline FloorMatcherOptions fastOptions() {
  FloorMatcherOptions o;
  o.seed = 7;
  o.filter.coarse_beams = 20;  // as config/floor_matcher.yaml
  return o;
}
}  // namespace storey::matching::test
