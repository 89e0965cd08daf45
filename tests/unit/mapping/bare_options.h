// The front end reduced to its core, for tests that check one mechanism at a time on the
// synthetic worlds: tracking refined on the likelihood field, normals taken as they are,
// no successor matches, loop closures searched within 4 m (10 m of candidates), each closure
// judged alone or in clusters without the region check, the uniqueness check or following a
// moved closure, and no robust kernel. A test turns on what it checks.
#pragma once

#include "storey/mapping/floor_slam_options.h"

namespace storey::mapping::test {

inline FloorSlamOptions bareOptions() {
  FloorSlamOptions o;
  o.matcher.point_refinement = false;
  o.matcher.normal_tilt_stddev = 0.0;
  o.loop_closure.matcher.normal_tilt_stddev = 0.0;
  o.successor_match_nodes = 0;
  o.loop_closure.max_search_radius = 10.0;
  o.loop_closure.max_linear_window = 4.0;
  o.loop_closure.cluster_verify_window = 0.0;
  o.loop_closure.follow_relocated = false;
  o.loop_closure.single_unique_distance = 0.0;
  o.loop_closure.single_unique_window = 0.0;
  o.optimizer = graph::OptimizerOptions{};
  return o;
}

}  // namespace storey::mapping::test
