#include "storey/building/isometric_view.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "storey/building/building_scene.h"

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

}  // namespace

grid::Image renderIsometric(const std::map<int, FloorMap>& floors, int width,
                            const BuildingGraph* graph, const BuildingSolution* solution,
                            bool constraints) {
  const BuildingScene scene = buildingScene(floors, graph, solution, constraints);
  if (scene.floors.empty() || width < 16) return grid::Image(1, 1, 3);
  // The plan's extent over all floors and the spacing of the floors' heights.
  double min_x = std::numeric_limits<double>::infinity(), min_y = min_x, max_x = -min_x,
         max_y = -min_x;
  std::vector<double> heights;
  for (const SceneFloor& f : scene.floors) {
    min_x = std::min(min_x, f.x0);
    min_y = std::min(min_y, f.y0);
    max_x = std::max(max_x, f.x1);
    max_y = std::max(max_y, f.y1);
    heights.push_back(f.height);
  }
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
  auto polyline = [&](const SceneLine& l) {
    for (std::size_t k = 1; k < l.points.size(); ++k) {
      const Eigen::Vector3d& a = l.points[k - 1];
      const Eigen::Vector3d& b = l.points[k];
      line(image, px(a.x(), a.y()), py(a.x(), a.y(), a.z()), px(b.x(), b.y()),
           py(b.x(), b.y(), b.z()), l.colour);
    }
  };

  // Lowest floor first, each with its outline, walls and paths before the floors above.
  for (const SceneFloor& f : scene.floors) {
    const double z = f.height;
    const Colour grey{170, 170, 170};
    line(image, px(f.x0, f.y0), py(f.x0, f.y0, z), px(f.x1, f.y0), py(f.x1, f.y0, z), grey);
    line(image, px(f.x1, f.y0), py(f.x1, f.y0, z), px(f.x1, f.y1), py(f.x1, f.y1, z), grey);
    line(image, px(f.x1, f.y1), py(f.x1, f.y1, z), px(f.x0, f.y1), py(f.x0, f.y1, z), grey);
    line(image, px(f.x0, f.y1), py(f.x0, f.y1, z), px(f.x0, f.y0), py(f.x0, f.y0, z), grey);
    for (const Eigen::Vector2d& w : f.walls)
      plot(image, static_cast<int>(px(w.x(), w.y())), static_cast<int>(py(w.x(), w.y(), z)),
           f.colour);
    for (const SceneLine& path : scene.paths)
      if (path.floor_id == f.floor_id) polyline(path);
  }
  for (const SceneLine& ride : scene.rides) polyline(ride);
  for (const SceneLine& c : scene.constraints) polyline(c);
  return image;
}

}  // namespace storey::building
