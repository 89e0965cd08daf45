#include "storey/mapping/floor_slam_options.h"

#include <cmath>

namespace storey::mapping {

namespace {

graph::OptimizerOptions floorOptimizer() {
  graph::OptimizerOptions o;
  // A wrong loop closure that slipped through every check must not bend the floor: its
  // weight falls off beyond a χ² of about 5 (dynamic covariance scaling).
  graph::RobustKernel dcs;
  dcs.type = graph::RobustKernelType::kDcs;
  dcs.delta = 5.0;
  o.robust[static_cast<std::size_t>(graph::EdgeKind::kLoopClosure)] = dcs;
  return o;
}

}  // namespace

FloorSlamOptions::FloorSlamOptions() : optimizer(floorOptimizer()) {
  // Tracking refines on the local map's points (sub-cell); closures on the field.
  matcher.point_refinement = true;
  // A closure search (and a cluster's check for a rival) is bounded in time: 3·10⁸ point
  // lookups, about 0.3 s of one core, which 15 s of recording pays for at 50× real time.
  // Weakly pruned searches (noisy scans against a graph uncertain by metres) reach it and
  // count as no match and no proof of uniqueness.
  loop_closure.matcher.max_lookups = 3e8;
  applyLaserModel(laser, this);
}

void applyLaserModel(const LaserModel& laser, FloorSlamOptions* o) {
  const double noise = laser.range_noise;
  // Points more precise than the grid's cells: matches refined on them say more than the
  // field does (precise), noisier points would only add their noise.
  const bool precise = noise < 0.5 * o->local_map.resolution;
  for (ScanMatcherOptions* m : {&o->matcher, &o->loop_closure.matcher}) {
    // A point's distance to its wall along the wall's normal varies with the beam's incidence:
    // about half the range noise on average. A match's own pose is known to about a quarter of
    // it at best (many points average, but neighbouring beams see the same errors).
    m->min_point_stddev = 0.5 * noise;
    m->min_translation_stddev = std::min(0.25 * noise, m->max_translation_stddev);
    // Normals fitted to noisy neighbours tilt, and along a bare corridor their tilt shows as
    // information along the axis that is noise: tilt² of the strongest direction's
    // information is taken off the weakest. Matches trusted to a finer point floor carry more
    // of it into the graph, so more is taken off (measured on the real logs, 0.045 rad, and
    // on the simulated featureless corridor, 0.1 rad: with 0.045 or 0.09 its loop closures
    // claimed metres they did not have).
    m->normal_tilt_stddev = precise ? 0.1 : 0.045;
  }
  // A loop closure's pose is polished on the map's points, by at most a cell and 0.03 rad
  // (the field's heading error in a 2 m cabin), when those points are the finer measure.
  o->loop_closure.point_polish_translation = precise ? o->local_map.resolution : 0.0;
  o->loop_closure.point_polish_rotation = precise ? 0.03 : 0.0;
}

FloorSlamOptions readFloorSlamOptions(const common::ConfigNode& node) {
  FloorSlamOptions o;
  if (node.has("laser")) {
    const auto n = node.child("laser");
    o.laser.range_noise = n.getDouble("range_noise", o.laser.range_noise, 1e-4, 1.0);
    n.finish();
  }
  if (node.has("odometry_noise")) {
    const auto n = node.child("odometry_noise");
    auto& m = o.odometry;
    m.translation_per_meter =
        n.getDouble("translation_per_meter", m.translation_per_meter, 0.0, 10.0);
    m.rotation_per_meter = n.getDouble("rotation_per_meter", m.rotation_per_meter, 0.0, 10.0);
    m.rotation_per_radian = n.getDouble("rotation_per_radian", m.rotation_per_radian, 0.0, 10.0);
    n.finish();
  }
  o.local_map.resolution = node.getDouble("map_resolution", o.local_map.resolution, 0.01, 0.5);
  // Points are kept one per cell, and refined against the map's points averaged per cell.
  o.local_map.point_cell_size = o.local_map.resolution;
  o.matcher.point_filter_distance = o.local_map.resolution;
  o.loop_closure.matcher.point_filter_distance = o.local_map.resolution;
  if (node.has("node_spacing")) {
    const auto n = node.child("node_spacing");
    o.node.min_translation = n.getDouble("translation", o.node.min_translation, 0.0, 100.0);
    o.node.min_rotation = n.getDouble("rotation", o.node.min_rotation, 0.0, M_PI);
    n.finish();
  }
  o.local_map.max_nodes = node.getInt("local_map_nodes", o.local_map.max_nodes, 2, 10000);
  o.loop_closure.enabled = node.get<bool>("loop_closure", o.loop_closure.enabled);
  if (node.has("relocalization")) {
    const auto n = node.child("relocalization");
    auto& r = o.relocalization;
    r.known_floor = n.getChoice("known_floor", r.known_floor, {"new_graph", "relocalize"});
    r.global.seed = static_cast<std::uint64_t>(
        n.getInt("seed", static_cast<long>(r.global.seed), 0, 2147483647L));
    n.finish();
  }
  node.finish();
  applyLaserModel(o.laser, &o);
  return o;
}

}  // namespace storey::mapping
