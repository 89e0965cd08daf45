#include "storey/grid/distance_transform.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::grid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// 1D squared distance transform of f (length n) into d: the lower envelope of the
// parabolas rooted at every finite sample. v holds the envelope's roots, z its breakpoints.
void transform1d(const float* f, int n, float* d, int* v, double* z) {
  int first = 0;
  while (first < n && f[first] == kInf) ++first;
  if (first == n) {
    std::fill(d, d + n, kInf);
    return;
  }
  int k = 0;
  v[0] = first;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = first + 1; q < n; ++q) {
    if (f[q] == kInf) continue;
    double s;
    while (true) {
      const int p = v[k];
      s = ((static_cast<double>(f[q]) + static_cast<double>(q) * q) -
           (static_cast<double>(f[p]) + static_cast<double>(p) * p)) /
          (2.0 * (q - p));
      if (s > z[k]) break;
      --k;  // z[0] is -inf, so k never drops below 0
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double diff = q - v[k];
    d[q] = static_cast<float>(diff * diff + f[v[k]]);
  }
}

}  // namespace

Grid2<float> squaredDistanceTransform(const GridFrame& frame, const std::vector<std::uint8_t>& is_source) {
  const int w = frame.width, h = frame.height;
  Grid2<float> out(frame, kInf);
  for (std::size_t i = 0; i < out.data.size(); ++i)
    if (is_source[i]) out.data[i] = 0.0f;
  const int n = std::max(w, h);
  std::vector<float> f(n), d(n);
  std::vector<double> z(n + 1);
  std::vector<int> v(n);
  // Columns first (stride w), then rows (contiguous).
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < h; ++y) f[y] = out.data[frame.index(x, y)];
    transform1d(f.data(), h, d.data(), v.data(), z.data());
    for (int y = 0; y < h; ++y) out.data[frame.index(x, y)] = d[y];
  }
  for (int y = 0; y < h; ++y) {
    float* row = &out.data[frame.index(0, y)];
    std::copy_n(row, w, f.data());
    transform1d(f.data(), w, row, v.data(), z.data());
  }
  return out;
}

Grid2<float> distanceField(const GridFrame& frame, const std::vector<std::uint8_t>& is_source,
                           double max_distance) {
  Grid2<float> field = squaredDistanceTransform(frame, is_source);
  const float res = static_cast<float>(frame.resolution), cap = static_cast<float>(max_distance);
  for (float& value : field.data) value = std::min(std::sqrt(value) * res, cap);
  return field;
}

}  // namespace storey::grid
