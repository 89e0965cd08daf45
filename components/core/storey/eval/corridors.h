// The corridors of a ground-truth folder (corridors.yaml written by the simulator):
//   corridors:
//     - {name: corridor_F0, floor: F0, from: [0.5, 6.0], to: [19.5, 6.0]}
#pragma once

#include <string>
#include <vector>

#include "storey/eval/metrics.h"

namespace storey::eval {

// An absent file gives no corridors; a malformed one throws common::ConfigError naming
// the file, key and line.
std::vector<CorridorSpec> readCorridors(const std::string& path);

}  // namespace storey::eval
