// A dense 2D grid of values over the plane. Cell (cx, cy) covers
// [origin_x + cx*res, origin_x + (cx+1)*res) x [origin_y + cy*res, ...); row-major, y up.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace storey::grid {

// floor() as an int without a libm call (x86-64 without SSE4.1 has no floor instruction);
// exact for every value an int holds.
inline int floorToInt(double v) {
  const int i = static_cast<int>(v);
  return i - (v < static_cast<double>(i));
}

struct GridFrame {
  double resolution = 0.05;
  double origin_x = 0.0;
  double origin_y = 0.0;
  int width = 0;
  int height = 0;

  Eigen::Vector2i cellOf(const Eigen::Vector2d& p) const {
    return {floorToInt((p.x() - origin_x) / resolution),
            floorToInt((p.y() - origin_y) / resolution)};
  }
  // Continuous cell coordinates: cell (cx, cy) has its centre at (cx + 0.5, cy + 0.5).
  Eigen::Vector2d continuousCellOf(const Eigen::Vector2d& p) const {
    return {(p.x() - origin_x) / resolution, (p.y() - origin_y) / resolution};
  }
  Eigen::Vector2d centerOf(int cx, int cy) const {
    return {origin_x + (cx + 0.5) * resolution, origin_y + (cy + 0.5) * resolution};
  }
  bool contains(int cx, int cy) const { return cx >= 0 && cy >= 0 && cx < width && cy < height; }
  std::size_t index(int cx, int cy) const {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(width) + static_cast<std::size_t>(cx);
  }
  std::size_t cellCount() const { return static_cast<std::size_t>(width) * static_cast<std::size_t>(height); }
  double maxX() const { return origin_x + width * resolution; }
  double maxY() const { return origin_y + height * resolution; }
};

// Most cells a grid built from input (a floor map, a rendered log) may have: 1e8 cells is
// 500 m x 500 m at 0.05 m, larger than any building mapped so far, and 600 MB with an
// occupancy grid's bookkeeping. An input that would need more (a pose 1e9 m away, a range
// of 1e30 m, a resolution of 1e-6 m) is refused instead of exhausting memory.
inline constexpr double kMaxGridCells = 1e8;

// Throws std::runtime_error when a grid of `width` x `height` cells (computed in double, so
// a size that overflows int is caught too) would exceed kMaxGridCells; `what` names the
// grid and where its extent comes from.
void checkGridSize(double width, double height, double resolution, const std::string& what);

// std::allocator, except that an element made without a value is default-initialised (left as
// it is for float or int) instead of value-initialised (zeroed). A grid that its builder
// writes cell by cell then costs no pass of zeros first; with freed memory kept for reuse
// (tools/storey/main.cpp), that pass was 8 % of a front-end run.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

// Marks a grid whose cells its builder writes, every one, before anything reads them.
struct Unfilled {};

template <typename T>
struct Grid2 {
  GridFrame frame;
  std::vector<T, DefaultInitAllocator<T>> data;

  Grid2() = default;
  Grid2(const GridFrame& f, T fill) : frame(f), data(f.cellCount(), fill) {}
  Grid2(const GridFrame& f, Unfilled) : frame(f), data(f.cellCount()) {}
  T& at(int cx, int cy) { return data[frame.index(cx, cy)]; }
  const T& at(int cx, int cy) const { return data[frame.index(cx, cy)]; }
  // The value at a cell, or `outside` beyond the grid.
  T valueOr(int cx, int cy, T outside) const { return frame.contains(cx, cy) ? at(cx, cy) : outside; }
};

}  // namespace storey::grid
