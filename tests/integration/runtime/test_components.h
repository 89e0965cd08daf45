// Small components for testing the runtime without storey's real components.
//   test_talker:   publishes FloorEvent (floor_id = 0, 1, 2, ...) on `topic` at `rate_hz`
//   test_listener: counts FloorEvents on `topic`, appends each floor_id to `output_file`,
//                  and asks the process to finish after `finish_after` messages (0: never)
//   test_crasher:  after `after_s` seconds active, exits with `exit_code`, or raises
//                  `signal` when it is non-zero
//   test_recorder: appends its lifecycle hooks to a shared list (see lifecycleLog())
#pragma once

#include <mutex>
#include <string>
#include <vector>

#include "storey/runtime/component_registry.h"

namespace storey::runtime::test {

void registerTestComponents(ComponentRegistry& registry);
// A registry holding only the test components above.
ComponentRegistry testRegistry();
// The whitespace-separated integers of a file (what test_listener wrote).
std::vector<int> readInts(const std::string& path);

// Hooks called on test_recorder components, as "name:hook".
std::vector<std::string> lifecycleLog();
void clearLifecycleLog();

}  // namespace storey::runtime::test
