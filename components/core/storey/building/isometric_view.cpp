#include "storey/building/isometric_view.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace storey::building {

namespace {

// Plan (x, y) and height z to picture coordinates before scaling: the plan turned by 45°
// and seen from 30° above.
struct Projection {
  double stretch = 1.0;  // height scale relative to the plan's
  double u(double x, double y) const { return (x - y) * std::cos(M_PI / 6); }
  double v(double x, double y, double z) const {
    return (x + y) * std::sin(M_PI / 6) + stretch * z;
  }
};

void plot(grid::Image& image, int x, int y, const std::array<std::uint8_t, 3>& colour) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::copy(colour.begin(), colour.end(), image.at(x, y));
}

// A line between two picture points, rounded to pixels.
void line(grid::Image& image, double x0, double y0, double x1, double y1,
          const std::array<std::uint8_t, 3>& colour) {
  grid::drawLine(image, static_cast<int>(std::lround(x0)), static_cast<int>(std::lround(y0)),
                 static_cast<int>(std::lround(x1)), static_cast<int>(std::lround(y1)), colour);
}

// The extent of a floor's occupied cells, 1 m around them (a grid holds room to grow).
struct Extent {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  bool empty() const { return !(x1 >= x0); }
};
Extent occupiedExtent(const grid::OccupancyGrid& grid) {
  Extent e;
  const grid::GridFrame& f = grid.frame();
  for (int cy = 0; cy < f.height; ++cy)
    for (int cx = 0; cx < f.width; ++cx) {
      if (grid.stateAt(cx, cy) != grid::CellState::kOccupied) continue;
      const Eigen::Vector2d c = f.centerOf(cx, cy);
      e.x0 = std::min(e.x0, c.x() - 1.0);
      e.y0 = std::min(e.y0, c.y() - 1.0);
      e.x1 = std::max(e.x1, c.x() + 1.0);
      e.y1 = std::max(e.y1, c.y() + 1.0);
    }
  return e;
}

}  // namespace

grid::Image renderIsometric(const std::map<int, FloorMap>& floors, int width,
                            const BuildingGraph* graph, const BuildingSolution* solution,
                            bool constraints) {
  // The plan's extent over all floors and the spacing of the floors' heights.
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x,
         max_y = -min_x;
  std::vector<double> heights;
  std::map<int, Extent> extents;
  for (const auto& [id, floor] : floors) {
    const Extent e = occupiedExtent(floor.grid);
    if (e.empty()) continue;
    extents[id] = e;
    min_x = std::min(min_x, e.x0);
    min_y = std::min(min_y, e.y0);
    max_x = std::max(max_x, e.x1);
    max_y = std::max(max_y, e.y1);
    heights.push_back(floor.height);
  }
  if (heights.empty() || width < 16) return grid::Image(1, 1, 3);
  std::sort(heights.begin(), heights.end());
  std::vector<double> gaps;
  for (std::size_t i = 1; i < heights.size(); ++i)
    if (heights[i] - heights[i - 1] > 1e-6) gaps.push_back(heights[i] - heights[i - 1]);
  Projection p;
  const double depth = (max_x - min_x + max_y - min_y) * std::sin(M_PI / 6);
  const double breadth = (max_x - min_x + max_y - min_y) * std::cos(M_PI / 6);
  if (!gaps.empty()) {
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    p.stretch = std::max(1.0, 0.5 * depth / gaps[gaps.size() / 2]);
    const double rise = heights.back() - heights.front();
    // At most twice as high as wide.
    if (rise > 0) p.stretch = std::min(p.stretch, std::max(1.0, (2.0 * breadth - depth) / rise));
  }
  // Picture bounds from the plan's corners at the lowest and highest floor.
  double u0 = std::numeric_limits<double>::infinity(), u1 = -u0, v0 = u0, v1 = -u0;
  for (const double x : {min_x, max_x})
    for (const double y : {min_y, max_y})
      for (const double z : {heights.front(), heights.back()}) {
        u0 = std::min(u0, p.u(x, y));
        u1 = std::max(u1, p.u(x, y));
        v0 = std::min(v0, p.v(x, y, z));
        v1 = std::max(v1, p.v(x, y, z));
      }
  const int margin = 10;
  const double scale = (width - 2 * margin) / std::max(u1 - u0, 1e-9);
  const int height = static_cast<int>(std::ceil((v1 - v0) * scale)) + 2 * margin;
  grid::Image image(width, height, 3, 255);
  auto px = [&](double x, double y) { return (p.u(x, y) - u0) * scale + margin; };
  auto py = [&](double x, double y, double z) {
    return height - 1 - ((p.v(x, y, z) - v0) * scale + margin);
  };

  std::vector<const FloorMap*> order;
  order.reserve(floors.size());
  for (const auto& [id, floor] : floors) order.push_back(&floor);
  std::stable_sort(order.begin(), order.end(),
                   [](const FloorMap* a, const FloorMap* b) { return a->height < b->height; });
  std::map<int, std::size_t> colour_index;
  for (const auto& [id, floor] : floors) colour_index.emplace(id, colour_index.size());
  // Robots' colours by name; a node's place in the building (position and height).
  std::map<std::string, std::size_t> robot_index;
  if (graph && solution)
    for (const auto& [id, g] : graph->floorGraphs()) robot_index.emplace(g.robot, 0);
  std::size_t next_robot = 0;
  for (auto& entry : robot_index) entry.second = next_robot++;
  auto nodeAt = [&](int graph_id, int node_id, double* x, double* y, double* z) {
    const auto pose = solution->poses.find({graph_id, node_id});
    const FloorPlacement* placement = solution->placement(graph_id);
    if (pose == solution->poses.end() || !placement) return false;
    *x = pose->second.x();
    *y = pose->second.y();
    *z = placement->height;
    return true;
  };
  // A floor's paths, drawn over its walls before the floors above.
  auto drawPaths = [&](int floor_id) {
    if (!graph || !solution) return;
    for (const auto& [id, g] : graph->floorGraphs()) {
      const FloorPlacement* placement = solution->placement(id);
      if (!placement || placement->floor_id != floor_id) continue;
      const auto colour = robotColour(robot_index.at(g.robot));
      const double z = placement->height;
      const geometry::Pose2* last = nullptr;
      for (const floor::FloorNode& n : g.nodes) {
        const auto pose = solution->poses.find({id, n.id});
        if (pose == solution->poses.end()) continue;
        const geometry::Pose2& at = pose->second;
        if (last)
          line(image, px(last->x(), last->y()), py(last->x(), last->y(), z), px(at.x(), at.y()),
               py(at.x(), at.y(), z), colour);
        last = &at;
      }
    }
  };
  for (const FloorMap* floor : order) {
    const auto extent = extents.find(floor->floor_id);
    if (extent == extents.end()) continue;
    const grid::GridFrame& f = floor->grid.frame();
    const double z = floor->height;
    const std::array<std::uint8_t, 3> grey{170, 170, 170};
    const Extent& e = extent->second;
    const double x0 = e.x0, y0 = e.y0, x1 = e.x1, y1 = e.y1;
    line(image, px(x0, y0), py(x0, y0, z), px(x1, y0), py(x1, y0, z), grey);
    line(image, px(x1, y0), py(x1, y0, z), px(x1, y1), py(x1, y1, z), grey);
    line(image, px(x1, y1), py(x1, y1, z), px(x0, y1), py(x0, y1, z), grey);
    line(image, px(x0, y1), py(x0, y1, z), px(x0, y0), py(x0, y0, z), grey);
    const auto colour = floorColour(colour_index.at(floor->floor_id));
    for (int cy = 0; cy < f.height; ++cy)
      for (int cx = 0; cx < f.width; ++cx) {
        if (floor->grid.stateAt(cx, cy) != grid::CellState::kOccupied) continue;
        const Eigen::Vector2d c = f.centerOf(cx, cy);
        plot(image, static_cast<int>(px(c.x(), c.y())), static_cast<int>(py(c.x(), c.y(), z)),
             colour);
      }
    drawPaths(floor->floor_id);
  }
  if (graph && solution) {
    // Rides: where a robot's nodes, in stamp order, pass from one floor graph to another.
    struct Visit {
      double stamp;
      int graph_id, node_id;
    };
    std::map<std::string, std::vector<Visit>> visits;
    for (const auto& [id, g] : graph->floorGraphs())
      for (const floor::FloorNode& n : g.nodes) visits[g.robot].push_back({n.stamp, id, n.id});
    for (auto& [robot, v] : visits) {
      std::stable_sort(v.begin(), v.end(),
                       [](const Visit& a, const Visit& b) { return a.stamp < b.stamp; });
      const auto colour = robotColour(robot_index.at(robot));
      for (std::size_t k = 1; k < v.size(); ++k) {
        if (v[k].graph_id == v[k - 1].graph_id) continue;
        double x0 = 0, y0 = 0, z0 = 0, x1 = 0, y1 = 0, z1 = 0;
        if (nodeAt(v[k - 1].graph_id, v[k - 1].node_id, &x0, &y0, &z0) &&
            nodeAt(v[k].graph_id, v[k].node_id, &x1, &y1, &z1))
          line(image, px(x0, y0), py(x0, y0, z0), px(x1, y1), py(x1, y1, z1), colour);
      }
    }
  }
  if (graph && solution && constraints)
    for (const auto& c : graph->constraints()) {
      const auto a = solution->poses.find({c.graph_from, c.node_from});
      const auto b = solution->poses.find({c.graph_to, c.node_to});
      const FloorPlacement* pa = solution->placement(c.graph_from);
      const FloorPlacement* pb = solution->placement(c.graph_to);
      if (a == solution->poses.end() || b == solution->poses.end() || !pa || !pb) continue;
      const geometry::Pose2& A = a->second;
      const geometry::Pose2& B = b->second;
      line(image, px(A.x(), A.y()), py(A.x(), A.y(), pa->height), px(B.x(), B.y()),
           py(B.x(), B.y(), pb->height), {0, 0, 0});
    }
  return image;
}

}  // namespace storey::building
