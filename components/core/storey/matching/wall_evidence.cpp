// Wall evidence: the solid walls of a floor map, beams that pass through them, and the
// check of two graphs of one floor against each other's walls.
#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "storey/common/log.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/floor_matcher_internal.h"
#include "storey/matching/retraction.h"

namespace storey::matching {

using namespace detail;  // NOLINT(google-build-using-namespace): the stages' shared helpers

std::vector<std::uint8_t> solidWalls(const grid::LikelihoodField& field,
                                     const floor::FloorGraph& graph, int beams) {
  const grid::GridFrame& f = field.frame();
  std::vector<std::uint8_t> solid(f.cellCount(), 0);
  for (std::size_t i = 0; i < solid.size(); ++i) solid[i] = field.distance().data[i] <= 0.0f;
  // A cell the floor's own beams passed through is not a wall that is always there (a
  // landing door that opened, a person): clear it. The last cells before each endpoint
  // are spared, so the wall a beam ends on stays.
  const double step = 0.5 * f.resolution, spare = 2.0 * f.resolution;
  for (const auto& node : graph.nodes) {
    const Eigen::Vector2d origin = (node.pose * node.scan.sensor_offset).translation();
    for (const auto& end : node.pose.transformPoints(selectBeams(node.scan, beams))) {
      const Eigen::Vector2d d = end - origin;
      const double length = d.norm();
      if (length <= spare) continue;
      const Eigen::Vector2d u = d / length;
      for (double t = step; t < length - spare; t += step) {
        const Eigen::Vector2i c = f.cellOf(origin + t * u);
        if (f.contains(c.x(), c.y())) solid[f.index(c.x(), c.y())] = 0;
      }
    }
  }
  return solid;
}

namespace {

// Of one node's scan (up to `beams` traced, placed at alignment * pose): how many beams
// cross a cell of `walls` more than `margin` before their endpoint (`through`), of `total`.
struct BeamsThroughWalls {
  std::size_t through = 0, total = 0;
};

BeamsThroughWalls beamsThroughWalls(const grid::GridFrame& f,
                                    const std::vector<std::uint8_t>& walls,
                                    const floor::FloorNode& node, int beams, const Pose2& alignment,
                                    double margin) {
  // Half-cell steps cannot jump over a wall one cell thick.
  const double step = 0.5 * f.resolution;
  BeamsThroughWalls count;
  const Pose2 robot = alignment * node.pose;
  const Eigen::Vector2d origin = (robot * node.scan.sensor_offset).translation();
  for (const Eigen::Vector2d& end : robot.transformPoints(selectBeams(node.scan, beams))) {
    const Eigen::Vector2d d = end - origin;
    const double length = d.norm() - margin;
    ++count.total;
    if (length <= 0.0) continue;
    const Eigen::Vector2d u = d / d.norm();
    for (double t = step; t < length; t += step) {
      const Eigen::Vector2i c = f.cellOf(origin + t * u);
      if (f.contains(c.x(), c.y()) && walls[f.index(c.x(), c.y())]) {
        ++count.through;
        break;
      }
    }
  }
  return count;
}

}  // namespace

double seeThroughFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                          const floor::FloorGraph& graph,
                          const std::vector<std::pair<int, int>>& ranges, int beams,
                          const Pose2& alignment, double margin) {
  std::size_t total = 0, through = 0;
  for (const auto& [first, last] : ranges) {
    for (int n = first; n <= last; ++n) {
      const BeamsThroughWalls count =
          beamsThroughWalls(f, walls, graph.nodes[n], beams, alignment, margin);
      through += count.through;
      total += count.total;
    }
  }
  return total ? static_cast<double>(through) / static_cast<double>(total) : 0.0;
}

double seeThroughScanFraction(const grid::GridFrame& f, const std::vector<std::uint8_t>& walls,
                              const floor::FloorGraph& graph, int beams, const Pose2& alignment,
                              int min_beams) {
  if (graph.nodes.empty()) return 0.0;
  int seeing = 0;
  for (const auto& node : graph.nodes)
    seeing += beamsThroughWalls(f, walls, node, beams, alignment, kWallMargin).through >=
              static_cast<std::size_t>(min_beams);
  return static_cast<double>(seeing) / static_cast<double>(graph.nodes.size());
}

void PreparedFloor::computeWalls(const FloorMatcherOptions& options) const {
  std::call_once(walls_->once, [&] {
    walls_->cells = solidWalls(map->field(), *graph, options.refine_beams);
    walls_->model = makeWallModel(map->frame(), walls_->cells);
  });
}

const std::vector<std::uint8_t>& PreparedFloor::walls(const FloorMatcherOptions& options) const {
  computeWalls(options);
  return walls_->cells;
}

const WallModel& PreparedFloor::wallModel(const FloorMatcherOptions& options) const {
  computeWalls(options);
  return walls_->model;
}

// Two graphs of one floor (one floor id: two robots', or a floor mapped again after a
// failed relocalisation) were built from the same walls, so at the right alignment
// neither graph's beams pass through the other's solid walls. A young graph placed a few
// rooms along a periodic row fits there locally, but its beams down the corridor then
// cross the other graph's end walls (and the other's beams its own). Empty when
// `alignment` (g_i's frame in g_ref's) is consistent, else what contradicts it.
std::string sameFloorContradiction(const PreparedFloor& reference, const PreparedFloor& floor_data,
                                   const Pose2& alignment, const FloorMatcherOptions& o) {
  const floor::FloorGraph& ref = *reference.graph;
  const floor::FloorGraph& g = *floor_data.graph;
  if (o.same_floor_see_through >= 1.0 || ref.graph_id == g.graph_id || ref.floor_id != g.floor_id ||
      ref.nodes.empty() || g.nodes.empty())
    return {};
  const double g_in_ref =
      seeThroughScanFraction(reference.map->frame(), reference.walls(o), g, o.refine_beams,
                             alignment, o.same_floor_through_beams);
  const double ref_in_g =
      seeThroughScanFraction(floor_data.map->frame(), floor_data.walls(o), ref, o.refine_beams,
                             alignment.inverse(), o.same_floor_through_beams);
  if (std::min(g_in_ref, ref_in_g) <= o.same_floor_see_through) return {};
  return common::str("graphs ", g.graph_id, " and ", ref.graph_id, " are of floor ", g.floor_id,
                     ", and ", g_in_ref, " of ", g.graph_id, "'s scans see through ", ref.graph_id,
                     "'s walls, ", ref_in_g, " the other way (at most ", o.same_floor_see_through,
                     ")");
}

}  // namespace storey::matching
