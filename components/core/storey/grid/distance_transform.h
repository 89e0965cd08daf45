// Exact Euclidean distance transform (Felzenszwalb & Huttenlocher 2012): linear time in
// the number of cells, separable into one 1D lower-envelope pass per column and per row.
#pragma once

#include <vector>

#include "storey/grid/grid2.h"

namespace storey::grid {

// Squared distance, in cells, from every cell to the nearest cell where `is_source` is true.
// Cells with no source anywhere get +infinity. With `max_distance` (cells, >= 0), only
// distances up to it are exact: a cell farther than that from every source gets some value
// above max_distance² (+infinity where no source is that close in any column), which is
// all a field capped there needs, and the transform skips the columns with no source within
// max_distance of the row.
Grid2<float> squaredDistanceTransform(const GridFrame& frame,
                                      const std::vector<std::uint8_t>& is_source,
                                      int max_distance = -1);

// Distance in metres to the nearest source cell, capped at `max_distance`.
Grid2<float> distanceField(const GridFrame& frame, const std::vector<std::uint8_t>& is_source,
                           double max_distance);

}  // namespace storey::grid
