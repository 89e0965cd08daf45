#include "storey/sim/pictures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>

namespace storey::sim {
namespace {

constexpr double kMaxPicturePixels = 2.5e7;

struct Frame {
  Eigen::Vector2d min;
  int width = 0, height = 0;
  double resolution = 0.05;
};

// One extent for every floor so pictures of different floors line up pixel for pixel.
Frame frameFor(const Building& building, const PictureOptions& options) {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = Eigen::Vector2d::Constant(-1e300);
  for (std::size_t f = 0; f < building.floors.size(); ++f)
    for (const auto& s : floorObstacles(building, static_cast<int>(f))) {
      lo = lo.cwiseMin(s.a).cwiseMin(s.b);
      hi = hi.cwiseMax(s.a).cwiseMax(s.b);
    }
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector2d::Zero();
  Frame frame;
  frame.min = lo - Eigen::Vector2d::Constant(options.margin);
  const Eigen::Vector2d extent = hi - lo + Eigen::Vector2d::Constant(2.0 * options.margin);
  // A building too large for the picture at this resolution is drawn coarser (a 2 km wall
  // at 0.05 m would need 1.6e9 pixels).
  frame.resolution =
      std::max(options.resolution, std::sqrt(extent.x() * extent.y() / kMaxPicturePixels));
  const Eigen::Vector2d size = extent / frame.resolution;
  frame.width = std::max(1, static_cast<int>(std::ceil(size.x())));
  frame.height = std::max(1, static_cast<int>(std::ceil(size.y())));
  return frame;
}

template <typename Paint>
void drawSegments(const Frame& frame, const std::vector<Segment>& segments, Paint&& paint) {
  for (const auto& s : segments) {
    const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * s.length() / frame.resolution)));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector2d p = s.a + (s.b - s.a) * (static_cast<double>(k) / steps);
      const int x = static_cast<int>(std::floor((p.x() - frame.min.x()) / frame.resolution));
      const int y = frame.height - 1 -
                    static_cast<int>(std::floor((p.y() - frame.min.y()) / frame.resolution));
      if (x >= 0 && y >= 0 && x < frame.width && y < frame.height) paint(x, y);
    }
  }
}

}  // namespace

grid::Image renderFloor(const Building& building, int floor, const PictureOptions& options) {
  const Frame frame = frameFor(building, options);
  grid::Image image(frame.width, frame.height, 1, 255);
  drawSegments(frame, floorObstacles(building, floor), [&](int x, int y) { *image.at(x, y) = 0; });
  return image;
}

grid::Image renderOverlay(const Building& building, const std::vector<int>& floors,
                          const PictureOptions& options) {
  static const std::array<std::array<std::uint8_t, 3>, 6> kColours = {{{{200, 30, 30}},
                                                                       {{30, 90, 200}},
                                                                       {{30, 150, 60}},
                                                                       {{200, 130, 0}},
                                                                       {{140, 40, 170}},
                                                                       {{0, 150, 150}}}};
  const Frame frame = frameFor(building, options);
  grid::Image image(frame.width, frame.height, 3, 255);
  for (std::size_t i = 0; i < floors.size(); ++i) {
    const auto& colour = kColours[i % kColours.size()];
    drawSegments(frame, floorObstacles(building, floors[i]), [&](int x, int y) {
      std::uint8_t* px = image.at(x, y);
      // Where floors agree the colours mix (darken), where they differ each shows alone.
      const bool blank = px[0] == 255 && px[1] == 255 && px[2] == 255;
      for (int c = 0; c < 3; ++c)
        px[c] = blank ? colour[c] : static_cast<std::uint8_t>((px[c] + colour[c]) / 3);
    });
  }
  return image;
}

std::vector<std::string> writePictures(const Building& building, const std::string& dir,
                                       const PictureOptions& options) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  std::vector<std::string> written;
  const auto save = [&](const std::string& name, const grid::Image& image) {
    const std::string path = (fs::path(dir) / name).string();
    grid::writePng(path, image);
    written.push_back(path);
  };
  std::vector<int> all;
  for (std::size_t f = 0; f < building.floors.size(); ++f) {
    all.push_back(static_cast<int>(f));
    save("floor_" + building.floors[f].id + ".png",
         renderFloor(building, static_cast<int>(f), options));
    if (f > 0)
      save("overlay_" + building.floors[f - 1].id + "_" + building.floors[f].id + ".png",
           renderOverlay(building, {static_cast<int>(f - 1), static_cast<int>(f)}, options));
  }
  save("overlay_all.png", renderOverlay(building, all, options));
  return written;
}

}  // namespace storey::sim
