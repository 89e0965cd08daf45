#include "storey/catalog/all_components.h"

// One include and one line per component kind, e.g.
//   #include "storey/floor_detector/floor_detector_component.h"
//   registry.add<floor_detector::FloorDetectorComponent>("floor_detector", "...");

#include "storey/floor_detector/floor_detector_component.h"
#include "storey/floor_mapper/floor_mapper_component.h"
#include "storey/floor_matcher/floor_matcher_component.h"
#include "storey/graph_server/graph_server.h"

namespace storey::catalog {

void registerStoreyComponents(runtime::ComponentRegistry& registry) {
  registry.add<floor_detector::FloorDetectorComponent>(
      "floor_detector", "floor changes of one robot from pressure (+ IMU, odometry, scan)");
  registry.add<floor_mapper::FloorMapperComponent>(
      "floor_mapper", "per-floor SLAM front end: scan matching, loop closure, one graph per floor");
  registry.add<floor_matcher::FloorMatcherComponent>(
      "floor_matcher", "inter-floor constraints: global MCL, likelihood gate, RANSAC");
  registry.add<graph_server::GraphServer>(
      "graph_server", "building graph: merges floor graphs and inter-floor constraints, optimises, journals");
}

}  // namespace storey::catalog
