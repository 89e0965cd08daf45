// `storey map` on a bag storey did not write: tests/data/third_party_bag/loop.mcap, made by
// Foxglove's MCAP writer and ROS 2 CDR serializer (make_bag.mjs there) in ROS 2's
// conventions: one robot, /scan, /odom, /tf_static, frames odom, base_link, base_scan,
// ros2msg schemas, zstd chunks. The floor's walls are known: the map must lie on them.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/tools/map_job.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;

constexpr int kThirdPartyDomain = 187;
// Where make_bag.mjs's robot takes its first scan (m, heading 0): one 0.4 s step at
// 0.4 m/s from the corner (1.75, 1.75) where its path starts.
constexpr double kStartX = 1.75 + 0.16, kStartY = 1.75;

// The walls make_bag.mjs casts its scans against (x0, y0, x1, y1 in metres).
std::vector<std::array<double, 4>> walls() {
  std::vector<std::array<double, 4>> w;
  auto box = [&](double x0, double y0, double x1, double y1) {
    w.push_back({x0, y0, x1, y0});
    w.push_back({x1, y0, x1, y1});
    w.push_back({x1, y1, x0, y1});
    w.push_back({x0, y1, x0, y0});
  };
  box(0, 0, 16, 10);
  box(3.5, 3.5, 12.5, 6.5);
  box(7.75, 0.75, 8.25, 1.25);
  w.push_back({5, 9, 5, 10});
  w.push_back({11, 9, 11, 10});
  w.push_back({15, 3, 16, 4});
  return w;
}

double distanceToWalls(double x, double y) {
  double best = 1e9;
  for (const auto& [x0, y0, x1, y1] : walls()) {
    const double ex = x1 - x0, ey = y1 - y0;
    const double t = std::clamp(((x - x0) * ex + (y - y0) * ey) / (ex * ex + ey * ey), 0.0, 1.0);
    best = std::min(best, std::hypot(x0 + t * ex - x, y0 + t * ey - y));
  }
  return best;
}

// The occupied cells' centres of a map_server map (trinary PGM: 0 occupied), on the floor.
std::vector<std::array<double, 2>> occupiedCells(const std::string& yaml_path) {
  const auto yaml = common::ConfigNode::loadFile(yaml_path).yaml();
  const double resolution = yaml["resolution"].as<double>();
  const double ox = yaml["origin"][0].as<double>(), oy = yaml["origin"][1].as<double>();
  std::ifstream pgm(fs::path(yaml_path).parent_path() / yaml["image"].as<std::string>(),
                    std::ios::binary);
  // Header tokens, comment lines (#) skipped.
  auto token = [&pgm] {
    std::string t;
    while (pgm >> t && t.front() == '#') {
      std::string rest;
      std::getline(pgm, rest);
    }
    return t;
  };
  const std::string magic = token();
  const int width = std::stoi(token()), height = std::stoi(token());
  token();  // maximum value
  pgm.get();
  EXPECT_EQ(magic, "P5");
  std::vector<unsigned char> pixels(static_cast<std::size_t>(width) *
                                    static_cast<std::size_t>(height));
  pgm.read(reinterpret_cast<char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
  std::vector<std::array<double, 2>> cells;
  for (int row = 0; row < height; ++row)
    for (int col = 0; col < width; ++col)
      if (pixels[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(col)] == 0)
        cells.push_back({kStartX + ox + (col + 0.5) * resolution,
                         kStartY + oy + (height - row - 0.5) * resolution});
  return cells;
}

// Mapped as one floor (no barometer or IMU), the laser's mounting found through base_link.
// The map's frame is the robot's pose at its first scan: in that frame nearly every
// occupied cell lies on a wall (within two cells), and nearly every part of every wall is
// mapped.
TEST(MapJobThirdParty, AForeignMcapBagInRos2ConventionsMapsOntoItsWalls) {
  const std::string dir = test::makeTempDir("storey_map_third_party");
  MapJobOptions options;
  options.domain_id = kThirdPartyDomain;
  options.quiet = true;
  options.output_dir = dir + "/out";
  options.inputs = {parseMapInput(test::sourceDir() + "/tests/data/third_party_bag/loop.mcap")};
  const MapJobResult result = runMapJob(options);
  EXPECT_EQ(result.outputs.floors, 1u);
  const auto cells = occupiedCells(dir + "/out/floor_0.yaml");
  ASSERT_GT(cells.size(), 500u);
  std::size_t on_walls = 0;
  for (const auto& [x, y] : cells) on_walls += distanceToWalls(x, y) <= 0.1;
  EXPECT_GE(static_cast<double>(on_walls), 0.95 * static_cast<double>(cells.size()))
      << on_walls << " of " << cells.size() << " occupied cells on a wall";
  // Points every 0.25 m along each wall: an occupied cell within 0.1 m of nearly all.
  std::size_t points = 0, seen = 0;
  for (const auto& [x0, y0, x1, y1] : walls()) {
    const int n = std::max(1, static_cast<int>(std::hypot(x1 - x0, y1 - y0) / 0.25));
    for (int i = 0; i <= n; ++i) {
      const double x = x0 + (x1 - x0) * i / n, y = y0 + (y1 - y0) * i / n;
      ++points;
      for (const auto& c : cells)
        if (std::hypot(c[0] - x, c[1] - y) <= 0.1) {
          ++seen;
          break;
        }
    }
  }
  EXPECT_GE(static_cast<double>(seen), 0.9 * static_cast<double>(points))
      << seen << " of " << points;
}

}  // namespace
}  // namespace storey::tools
