// Shared by the matching unit tests: pose errors, the matcher's test options and a
// floor with a twin for every pose.
#pragma once

#include <cmath>

#include "storey/geometry/pose2.h"
#include "storey/matching/floor_matcher.h"
#include "synthetic_floor.h"

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
  // driveFloor's floors are driven one after the other by one robot with no ride between
  // them: there is no floor change to check a placement against.
  o.floor_change = {};
  return o;
}

// A floor with 180-degree rotational symmetry: every pose has a twin.
inline Walls symmetricFloor() {
  Walls w;
  test::addBox(&w, 0, 0, 16, 8);
  test::addBox(&w, 3, 3, 5, 5);
  test::addBox(&w, 11, 3, 13, 5);
  test::addWall(&w, 8, 0, 8, 2.5);
  test::addWall(&w, 8, 5.5, 8, 8);
  return w;
}

}  // namespace storey::matching::test
