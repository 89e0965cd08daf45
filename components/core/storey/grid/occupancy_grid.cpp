#include "storey/grid/occupancy_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace storey::grid {
namespace {
double probabilityFromLogOdds(double l) { return 1.0 - 1.0 / (1.0 + std::exp(l)); }
}  // namespace

OccupancyGrid::OccupancyGrid(const OccupancyGridOptions& options) : options_(options) {
  if (!(options_.resolution > 0.0)) throw std::invalid_argument("occupancy grid resolution must be > 0");
  log_odds_.frame.resolution = options_.resolution;
}

double OccupancyGrid::probabilityAt(int cx, int cy) const {
  return probabilityFromLogOdds(logOddsAt(cx, cy));
}

CellState OccupancyGrid::stateAt(int cx, int cy, double occupied_threshold,
                                 double free_threshold) const {
  const float l = logOddsAt(cx, cy);
  if (l == 0.0f) return CellState::kUnknown;
  const double p = probabilityFromLogOdds(l);
  if (p > occupied_threshold) return CellState::kOccupied;
  if (p < free_threshold) return CellState::kFree;
  return CellState::kUnknown;
}

std::array<std::size_t, 3> OccupancyGrid::countStates() const {
  std::array<std::size_t, 3> counts{0, 0, 0};
  const GridFrame& f = frame();
  for (int cy = 0; cy < f.height; ++cy)
    for (int cx = 0; cx < f.width; ++cx) ++counts[static_cast<int>(stateAt(cx, cy))];
  return counts;
}

void checkGridSize(double width, double height, double resolution, const std::string& what) {
  if (width * height <= kMaxGridCells) return;
  std::ostringstream out;
  out << what << ": " << width << " x " << height << " cells (" << width * resolution << " m x "
      << height * resolution << " m at " << resolution << " m per cell), more than the "
      << kMaxGridCells << " cells a map may hold";
  throw std::runtime_error(out.str());
}

void OccupancyGrid::ensureContains(const Eigen::Vector2d& min_corner,
                                   const Eigen::Vector2d& max_corner) {
  GridFrame& f = log_odds_.frame;
  const double res = f.resolution;
  const double margin = options_.growth_margin;  // room added, so growth happens rarely
  {
    // The extent after growing, in cells, before any int conversion.
    const double lo_x = std::min(min_corner.x(), f.width ? f.origin_x : min_corner.x()) - margin;
    const double lo_y = std::min(min_corner.y(), f.width ? f.origin_y : min_corner.y()) - margin;
    const double hi_x = std::max(max_corner.x(), f.width ? f.maxX() : max_corner.x()) + margin;
    const double hi_y = std::max(max_corner.y(), f.width ? f.maxY() : max_corner.y()) + margin;
    const double cells_x = std::ceil((hi_x - lo_x) / res) + 2,
                 cells_y = std::ceil((hi_y - lo_y) / res) + 2;
    if (!(cells_x * cells_y <= kMaxGridCells)) {  // NaN and infinity included
      std::ostringstream what;
      what << "an occupancy grid reaching from (" << lo_x << ", " << lo_y << ") to (" << hi_x
           << ", " << hi_y << ") m";
      checkGridSize(cells_x, cells_y, res, what.str());
    }
  }
  if (f.width == 0) {
    GridFrame fresh = f;
    fresh.origin_x = std::floor((min_corner.x() - margin) / res) * res;
    fresh.origin_y = std::floor((min_corner.y() - margin) / res) * res;
    fresh.width = static_cast<int>(std::ceil((max_corner.x() + margin - fresh.origin_x) / res));
    fresh.height = static_cast<int>(std::ceil((max_corner.y() + margin - fresh.origin_y) / res));
    log_odds_ = Grid2<float>(fresh, 0.0f);
    return;
  }
  if (min_corner.x() >= f.origin_x && min_corner.y() >= f.origin_y && max_corner.x() < f.maxX() &&
      max_corner.y() < f.maxY())
    return;
  // Grow by whole cells so existing cells keep their world position.
  const int add_left = min_corner.x() < f.origin_x
                           ? static_cast<int>(std::ceil((f.origin_x - min_corner.x() + margin) / res))
                           : 0;
  const int add_bottom = min_corner.y() < f.origin_y
                             ? static_cast<int>(std::ceil((f.origin_y - min_corner.y() + margin) / res))
                             : 0;
  const int add_right = max_corner.x() >= f.maxX()
                            ? static_cast<int>(std::ceil((max_corner.x() - f.maxX() + margin) / res))
                            : 0;
  const int add_top = max_corner.y() >= f.maxY()
                          ? static_cast<int>(std::ceil((max_corner.y() - f.maxY() + margin) / res))
                          : 0;
  GridFrame grown = f;
  grown.origin_x -= add_left * res;
  grown.origin_y -= add_bottom * res;
  grown.width += add_left + add_right;
  grown.height += add_bottom + add_top;
  Grid2<float> next(grown, 0.0f);
  for (int cy = 0; cy < f.height; ++cy)
    std::copy_n(&log_odds_.data[f.index(0, cy)], f.width, &next.data[grown.index(add_left, cy + add_bottom)]);
  log_odds_ = std::move(next);
}

inline void OccupancyGrid::addLogOdds(std::size_t index, double delta) {
  float& cell = log_odds_.data[index];
  cell = static_cast<float>(std::clamp(cell + delta, options_.min_log_odds, options_.max_log_odds));
  // Exactly zero means "never observed"; keep observed cells distinguishable.
  if (cell == 0.0f) cell = delta > 0 ? 1e-6f : -1e-6f;
}

template <typename Visit>
void OccupancyGrid::traceRay(const Eigen::Vector2d& from, const Eigen::Vector2d& to, Visit&& visit) const {
  const GridFrame& f = log_odds_.frame;
  const Eigen::Vector2d a = f.continuousCellOf(from), b = f.continuousCellOf(to);
  int cx = floorToInt(a.x()), cy = floorToInt(a.y());
  const int end_x = floorToInt(b.x()), end_y = floorToInt(b.y());
  const Eigen::Vector2d d = b - a;
  const int step_x = d.x() > 0 ? 1 : -1, step_y = d.y() > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  // Parameter t along the ray at which the next vertical / horizontal cell border is crossed.
  double t_max_x = d.x() != 0 ? ((step_x > 0 ? cx + 1 - a.x() : a.x() - cx) / std::abs(d.x())) : inf;
  double t_max_y = d.y() != 0 ? ((step_y > 0 ? cy + 1 - a.y() : a.y() - cy) / std::abs(d.y())) : inf;
  const double t_delta_x = d.x() != 0 ? 1.0 / std::abs(d.x()) : inf;
  const double t_delta_y = d.y() != 0 ? 1.0 / std::abs(d.y()) : inf;
  const int max_steps = std::abs(end_x - cx) + std::abs(end_y - cy);
  // The cell index is stepped along with the cell (the grid contains the whole ray).
  std::ptrdiff_t index = static_cast<std::ptrdiff_t>(f.index(cx, cy));
  const std::ptrdiff_t index_step_y = step_y * static_cast<std::ptrdiff_t>(f.width);
  for (int i = 0; i < max_steps; ++i) {
    visit(static_cast<std::size_t>(index));
    if (t_max_x < t_max_y) {
      t_max_x += t_delta_x;
      index += step_x;
    } else {
      t_max_y += t_delta_y;
      index += index_step_y;
    }
  }
}

bool OccupancyGrid::collectBeams(const sensor::LaserScan& scan, const geometry::Pose2& robot_pose,
                                Eigen::Vector2d* origin_out, std::vector<Beam>* beams) const {
  beams->clear();
  if (!scan.validate().empty() || !robot_pose.isFinite()) return false;
  const geometry::Pose2 sensor_pose = robot_pose * scan.sensor_offset;
  const Eigen::Vector2d origin = sensor_pose.translation();
  *origin_out = origin;
  const double insert_max =
      options_.max_insert_range > 0.0 ? std::min(options_.max_insert_range, scan.range_max) : scan.range_max;
  beams->reserve(scan.size());
  // Directions in the sensor frame (computed once per sensor) turned by the sensor's heading.
  const auto directions = scan.beamDirections();
  const Eigen::Matrix2d turn = sensor_pose.rotation();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector2d dir = turn * (*directions)[i];
    if (scan.isReturn(i) && scan.ranges[i] < insert_max) {
      beams->push_back({origin + dir * scan.ranges[i], true});
    } else if (options_.free_space_for_no_return) {
      const float r = scan.ranges[i];
      // A beam that ended on something beyond the insert range still proves free space.
      const bool beyond = scan.isReturn(i) || (std::isfinite(r) && r >= scan.range_max) ||
                          std::isinf(r);
      if (!beyond) continue;
      beams->push_back({origin + dir * std::min(options_.no_return_free_range, insert_max), false});
    }
  }
  return !beams->empty();
}

void OccupancyGrid::insertScan(const sensor::LaserScan& scan, const geometry::Pose2& robot_pose) {
  insertScans({{&scan, robot_pose}});
}

void OccupancyGrid::insertScans(const std::vector<PosedScan>& scans) {
  std::vector<std::vector<Beam>> beams(scans.size());
  std::vector<Eigen::Vector2d> origins(scans.size());
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Vector2d lo(inf, inf), hi(-inf, -inf);
  for (std::size_t k = 0; k < scans.size(); ++k) {
    if (!collectBeams(*scans[k].scan, scans[k].robot_pose, &origins[k], &beams[k])) continue;
    lo = lo.cwiseMin(origins[k]);
    hi = hi.cwiseMax(origins[k]);
    for (const Beam& beam : beams[k]) {
      lo = lo.cwiseMin(beam.end);
      hi = hi.cwiseMax(beam.end);
    }
  }
  if (!(lo.x() <= hi.x())) return;  // no scan has a beam
  ensureContains(lo, hi);
  for (std::size_t k = 0; k < scans.size(); ++k)
    if (!beams[k].empty()) applyBeams(origins[k], beams[k]);
}

void OccupancyGrid::applyBeams(const Eigen::Vector2d& origin, const std::vector<Beam>& beams) {
  // Each cell gets at most one update per scan, and a cell that holds an endpoint in this
  // scan is never cleared by a neighbouring beam passing through it: endpoints are marked
  // with this scan's hit tag first, then traversed cells not yet tagged get the miss.
  const GridFrame& f = log_odds_.frame;
  if (marks_.size() != f.cellCount()) marks_.assign(f.cellCount(), 0);
  if (last_tag_ > std::numeric_limits<std::uint16_t>::max() - 2) {
    std::fill(marks_.begin(), marks_.end(), 0);
    last_tag_ = 0;
  }
  const std::uint16_t hit_tag = ++last_tag_, miss_tag = ++last_tag_;
  for (const Beam& beam : beams) {
    if (!beam.hit) continue;
    const Eigen::Vector2i end = f.cellOf(beam.end);
    const std::size_t index = f.index(end.x(), end.y());
    if (marks_[index] == hit_tag) continue;
    marks_[index] = hit_tag;
    addLogOdds(index, options_.hit_log_odds);
  }
  auto miss = [&](std::size_t index) {
    std::uint16_t& mark = marks_[index];
    if (mark == hit_tag || mark == miss_tag) return;
    mark = miss_tag;
    addLogOdds(index, options_.miss_log_odds);
  };
  for (const Beam& beam : beams) {
    traceRay(origin, beam.end, miss);
    if (!beam.hit) {
      const Eigen::Vector2i end = f.cellOf(beam.end);
      miss(f.index(end.x(), end.y()));
    }
  }
}

Image renderGrey(const OccupancyGrid& grid, double occupied_threshold, double free_threshold) {
  const GridFrame& f = grid.frame();
  Image image(f.width, f.height, 1);
  auto& pixels = image.pixels;
  for (int cy = 0; cy < f.height; ++cy) {
    const int row = f.height - 1 - cy;
    for (int cx = 0; cx < f.width; ++cx) {
      std::uint8_t value = 205;
      switch (grid.stateAt(cx, cy, occupied_threshold, free_threshold)) {
        case CellState::kOccupied: value = 0; break;
        case CellState::kFree: value = 254; break;
        case CellState::kUnknown: value = 205; break;
      }
      pixels[static_cast<std::size_t>(row) * f.width + cx] = value;
    }
  }
  return image;
}

void writeMapServerFiles(const OccupancyGrid& grid, const std::string& stem,
                         double occupied_threshold, double free_threshold) {
  const GridFrame& f = grid.frame();
  const std::string pgm_path = stem + ".pgm", yaml_path = stem + ".yaml";
  {
    std::ofstream pgm(pgm_path, std::ios::binary);
    if (!pgm) throw std::runtime_error(pgm_path + ": cannot open for writing");
    pgm << "P5\n# storey occupancy grid\n" << f.width << " " << f.height << "\n255\n";
    const auto pixels = renderGrey(grid, occupied_threshold, free_threshold).pixels;
    pgm.write(reinterpret_cast<const char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
    if (!pgm) throw std::runtime_error(pgm_path + ": write failed");
  }
  std::ofstream yaml(yaml_path);
  if (!yaml) throw std::runtime_error(yaml_path + ": cannot open for writing");
  const std::size_t slash = pgm_path.find_last_of('/');
  yaml << std::setprecision(10) << "image: "
       << (slash == std::string::npos ? pgm_path : pgm_path.substr(slash + 1)) << "\n"
       << "mode: trinary\n"
       << "resolution: " << f.resolution << "\n"
       << "origin: [" << f.origin_x << ", " << f.origin_y << ", 0.0]\n"
       << "negate: 0\n"
       << "occupied_thresh: " << occupied_threshold << "\n"
       << "free_thresh: " << free_threshold << "\n";
  if (!yaml) throw std::runtime_error(yaml_path + ": write failed");
}

}  // namespace storey::grid
