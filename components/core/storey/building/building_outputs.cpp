#include "storey/building/building_outputs.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace storey::building {

std::map<int, FloorMap> renderBuildingFloors(const BuildingGraph& graph, const BuildingSolution& solution,
                                             const grid::OccupancyGridOptions& options) {
  std::map<int, FloorMap> floors;
  for (const auto& [g, fg] : graph.floorGraphs()) {
    auto it = floors.find(fg.floor_id);
    if (it == floors.end()) {
      it = floors.emplace(fg.floor_id, FloorMap{fg.floor_id, fg.floor_height, grid::OccupancyGrid(options)}).first;
    }
    for (const auto& node : fg.nodes) {
      auto pose = solution.poses.find({g, node.id});
      it->second.grid.insertScan(node.scan, pose == solution.poses.end() ? node.pose : pose->second);
    }
  }
  return floors;
}

std::size_t writeBuildingOctomap(const std::string& path, const std::map<int, FloorMap>& floors,
                                 const OctomapOptions& options) {
  if (!(options.resolution > 0.0) || !(options.wall_height > 0.0))
    throw std::invalid_argument(path + ": OctoMap resolution and wall height must be > 0");
  octomap::OcTree tree(options.resolution);
  // OcTree keys reach +-32768 voxels from the origin; points beyond are silently dropped.
  const double reach = 32768.0 * options.resolution;
  for (const auto& [id, floor] : floors) {
    const grid::GridFrame& f = floor.grid.frame();
    const double extent = std::max({std::abs(f.origin_x), std::abs(f.origin_y), std::abs(f.maxX()),
                                    std::abs(f.maxY()), std::abs(floor.height),
                                    std::abs(floor.height + options.wall_height)});
    if (!(extent < reach)) {
      std::ostringstream out;
      out << path << ": floor " << id << " reaches " << extent
          << " m from the origin, beyond the OctoMap's +-" << reach << " m at "
          << options.resolution << " m voxels";
      throw std::runtime_error(out.str());
    }
  }
  const int layers = std::max(1, static_cast<int>(std::round(options.wall_height / options.resolution)));
  for (const auto& [id, floor] : floors) {
    const grid::GridFrame& f = floor.grid.frame();
    // Occupancy is sampled at the voxel resolution, so coarse voxels do not skip thin walls.
    const int step = std::max(1, static_cast<int>(std::floor(options.resolution / f.resolution)));
    for (int cy = 0; cy < f.height; cy += step) {
      for (int cx = 0; cx < f.width; cx += step) {
        bool occupied = false, free = false;
        for (int dy = 0; dy < step && !occupied; ++dy)
          for (int dx = 0; dx < step; ++dx) {
            const auto state = floor.grid.stateAt(cx + dx, cy + dy);
            occupied |= state == grid::CellState::kOccupied;
            free |= state == grid::CellState::kFree;
          }
        if (!occupied && !free) continue;
        const Eigen::Vector2d c = f.centerOf(cx, cy) + Eigen::Vector2d::Constant((step - 1) * 0.5 * f.resolution);
        if (occupied) {
          for (int layer = 0; layer < layers; ++layer) {
            const double z = floor.height + (layer + 0.5) * options.resolution;
            tree.updateNode(octomap::point3d(float(c.x()), float(c.y()), float(z)), true, true);
          }
        } else {
          tree.updateNode(octomap::point3d(float(c.x()), float(c.y()), float(floor.height + options.sensor_height)),
                          false, true);
        }
      }
    }
  }
  tree.updateInnerOccupancy();
  std::size_t occupied = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
    if (tree.isNodeOccupied(*it)) ++occupied;
  if (!tree.writeBinary(path)) throw std::runtime_error(path + ": cannot write the OctoMap");
  return occupied;
}

void writeBuildingYaml(const std::string& path, const BuildingSolution& solution,
                       const std::map<int, FloorMap>& floors) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << std::setprecision(10);
  out << "# storey building: every floor graph's frame placed in the building frame\n";
  out << "reference_graph: " << solution.reference_graph << "\n";
  out << "chi2: {initial: " << solution.initial_chi2 << ", final: " << solution.final_chi2
      << ", iterations: " << solution.iterations << "}\n";
  out << "floors:\n";
  for (const auto& [id, floor] : floors) {
    out << "  - id: " << id << "\n    height: " << floor.height << "\n    map: floor_" << id << ".yaml\n";
  }
  out << "floor_graphs:\n";
  for (const auto& p : solution.placements) {
    out << "  - graph: " << p.graph_id << "\n    robot: \"" << p.robot << "\"\n    floor: " << p.floor_id
        << "\n    height: " << p.height << "\n    aligned: " << (p.aligned ? "true" : "false")
        << "\n    transform: {x: " << p.transform.x() << ", y: " << p.transform.y()
        << ", theta: " << p.transform.theta() << "}\n";
  }
  if (!out) throw std::runtime_error(path + ": write failed");
}

std::array<std::uint8_t, 3> floorColour(std::size_t index) {
  static constexpr std::array<std::array<std::uint8_t, 3>, 8> kColours{{{220, 30, 30},
                                                                       {30, 110, 220},
                                                                       {20, 160, 60},
                                                                       {230, 140, 0},
                                                                       {140, 40, 180},
                                                                       {0, 170, 170},
                                                                       {120, 80, 30},
                                                                       {200, 0, 120}}};
  return kColours[index % kColours.size()];
}

std::array<std::uint8_t, 3> robotColour(std::size_t index) {
  static constexpr std::array<std::array<std::uint8_t, 3>, 4> kColours{
      {{110, 110, 110}, {0, 80, 160}, {160, 80, 0}, {110, 0, 130}}};
  return kColours[index % kColours.size()];
}

grid::Image renderFloorOverlay(const std::map<int, FloorMap>& floors) {
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x, max_y = -min_x, res = 0.05;
  for (const auto& [id, floor] : floors) {
    const grid::GridFrame& f = floor.grid.frame();
    if (f.width == 0) continue;
    res = f.resolution;
    min_x = std::min(min_x, f.origin_x);
    min_y = std::min(min_y, f.origin_y);
    max_x = std::max(max_x, f.maxX());
    max_y = std::max(max_y, f.maxY());
  }
  if (!(max_x > min_x)) return grid::Image(1, 1, 3);
  const int w = static_cast<int>(std::ceil((max_x - min_x) / res)), h = static_cast<int>(std::ceil((max_y - min_y) / res));
  grid::Image image(w, h, 3, 255);
  int index = 0;
  for (const auto& [id, floor] : floors) {
    const auto colour = floorColour(index++);
    const grid::GridFrame& f = floor.grid.frame();
    for (int cy = 0; cy < f.height; ++cy)
      for (int cx = 0; cx < f.width; ++cx) {
        if (floor.grid.stateAt(cx, cy) != grid::CellState::kOccupied) continue;
        const Eigen::Vector2d c = f.centerOf(cx, cy);
        const int x = static_cast<int>((c.x() - min_x) / res), y = h - 1 - static_cast<int>((c.y() - min_y) / res);
        if (x < 0 || y < 0 || x >= w || y >= h) continue;
        std::copy(colour.begin(), colour.end(), image.at(x, y));
      }
  }
  return image;
}

}  // namespace storey::building
