#include "storey/grid/distance_transform.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace storey::grid {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Each cell's distance to the nearest source in its column; written in full before it is read.
using ColumnDistances = std::vector<std::int32_t, DefaultInitAllocator<std::int32_t>>;

// Phase 2 of the transform over every row: g holds each cell's distance to the nearest
// source in its column. Only the columns listed for a row enter its lower envelope (all of
// them for the exact transform; those with a source close enough for a bounded one).
// One row's envelope state; two rows advance in lockstep so that their independent
// dependency chains overlap in the processor.
template <typename Int>
struct Envelope {
  Int* s;
  Int* t;
  const Int* g2;
  int q = -1;
  void start(Int first) {
    q = 0;
    s[0] = first;
    t[0] = 0;
  }
  inline void add(Int u, int w, const double* half_inverse) {
    while (q >= 0) {
      const Int dq = t[q] - s[q], du = t[q] - u;
      if (dq * dq + g2[s[q]] <= du * du + g2[u]) break;
      --q;
    }
    if (q < 0) {
      q = 0;
      s[0] = u;
    } else {
      const Int i = s[q];
      const Int sep = static_cast<Int>(
          static_cast<double>(u * u - i * i + g2[u] - g2[i]) * half_inverse[u - i] + 1e-7);
      const Int begin = sep + 1;
      if (begin < w) {
        ++q;
        s[q] = u;
        t[q] = begin;
      }
    }
  }
  void emit(int w, float* row) {
    for (int uc = w - 1; uc >= 0; --uc) {
      const Int u = uc;
      const Int d = u - s[q];
      row[uc] = static_cast<float>(d * d + g2[s[q]]);
      if (u == t[q]) --q;
    }
  }
};

template <typename Int>
void lowerEnvelopeRows(const GridFrame& frame, const ColumnDistances& g,
                       std::int32_t max_column_distance, Grid2<float>* out) {
  const int w = frame.width, h = frame.height;
  std::vector<Int> buffer(6 * static_cast<std::size_t>(w));
  std::vector<Int> columns(2 * static_cast<std::size_t>(w));
  std::vector<double> half_inverse(w);
  for (int d = 1; d < w; ++d) half_inverse[d] = 0.5 / d;
  Envelope<Int> e[2];
  int count[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    e[k].s = &buffer[(3 * k) * w];
    e[k].t = &buffer[(3 * k + 1) * w];
    e[k].g2 = &buffer[(3 * k + 2) * w];
  }
  // Row y into slot k: its squared column distances and the columns that take part.
  auto load = [&](int k, int y) {
    const std::int32_t* gr = &g[frame.index(0, y)];
    Int* g2 = &buffer[(3 * k + 2) * w];
    Int* listed = &columns[k * static_cast<std::size_t>(w)];
    int n = 0;
    for (int x = 0; x < w; ++x) {
      g2[x] = static_cast<Int>(gr[x]) * gr[x];
      listed[n] = x;
      n += gr[x] <= max_column_distance;
    }
    count[k] = n;
    if (n > 0) e[k].start(listed[0]);
  };
  auto finish = [&](int k, int y) {
    float* row = &out->data[frame.index(0, y)];
    if (count[k] > 0)
      e[k].emit(w, row);
    else
      std::fill(row, row + w, kInf);  // no source near enough
  };
  int y = 0;
  for (; y + 1 < h; y += 2) {
    load(0, y);
    load(1, y + 1);
    const Int* c0 = &columns[0];
    const Int* c1 = &columns[w];
    const int both = std::min(count[0], count[1]);
    int i = 1;
    for (; i < both; ++i) {
      e[0].add(c0[i], w, half_inverse.data());
      e[1].add(c1[i], w, half_inverse.data());
    }
    for (int j = i; j < count[0]; ++j) e[0].add(c0[j], w, half_inverse.data());
    for (int j = i; j < count[1]; ++j) e[1].add(c1[j], w, half_inverse.data());
    finish(0, y);
    finish(1, y + 1);
  }
  if (y < h) {
    load(0, y);
    for (int j = 1; j < count[0]; ++j) e[0].add(columns[j], w, half_inverse.data());
    finish(0, y);
  }
}

}  // namespace

// Meijster, Roerdink & Hesselink (2000), exact and linear like Felzenszwalb & Huttenlocher
// but cheaper on a binary input. Phase 1, per column, is the distance to the nearest source
// in that column, computed with two sweeps over whole rows (contiguous, vectorisable).
// Phase 2, per row, is the lower envelope of the parabolas (x - i)^2 + g(i)^2, in integers.
Grid2<float> squaredDistanceTransform(const GridFrame& frame,
                                      const std::vector<std::uint8_t>& is_source,
                                      int max_distance) {
  const int w = frame.width, h = frame.height;
  if (w <= 0 || h <= 0) return Grid2<float>(frame, kInf);
  if (std::find_if(is_source.begin(),
                   is_source.begin() + static_cast<std::ptrdiff_t>(frame.cellCount()),
                   [](std::uint8_t s) { return s != 0; }) ==
      is_source.begin() + static_cast<std::ptrdiff_t>(frame.cellCount()))
    return Grid2<float>(frame, kInf);   // no source anywhere: every distance is infinite
  Grid2<float> out(frame, Unfilled{});  // every row written by the envelope pass
  // A column without a source gets g = w + h: its parabolas, at least (w + h)^2, never beat
  // a real source (at most (w-1)^2 + (h-1)^2 away), and some column has one. Bounded, a
  // column whose nearest source is farther than max_distance from the row leaves the row's
  // envelope: through it every distance is above max_distance anyway.
  const std::int32_t none = w + h;
  const std::int32_t max_column_distance = max_distance >= 0 ? std::min(max_distance, none) : none;
  ColumnDistances g(frame.cellCount());
  for (int x = 0; x < w; ++x) g[x] = is_source[x] ? 0 : none;
  for (int y = 1; y < h; ++y) {
    const std::uint8_t* src = &is_source[frame.index(0, y)];
    const std::int32_t* above = &g[frame.index(0, y - 1)];
    std::int32_t* row = &g[frame.index(0, y)];
    for (int x = 0; x < w; ++x) row[x] = src[x] ? 0 : std::min(above[x] + 1, none);
  }
  for (int y = h - 2; y >= 0; --y) {
    const std::int32_t* below = &g[frame.index(0, y + 1)];
    std::int32_t* row = &g[frame.index(0, y)];
    for (int x = 0; x < w; ++x) row[x] = std::min(row[x], below[x] + 1);
  }
  // 32-bit arithmetic is faster and exact while the largest term fits (grids up to ~20000
  // cells across); beyond that, 64-bit.
  const std::int64_t largest = 3 * static_cast<std::int64_t>(none) * none;
  if (largest < std::numeric_limits<std::int32_t>::max())
    lowerEnvelopeRows<std::int32_t>(frame, g, max_column_distance, &out);
  else
    lowerEnvelopeRows<std::int64_t>(frame, g, max_column_distance, &out);
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
