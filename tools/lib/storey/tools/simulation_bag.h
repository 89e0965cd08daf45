// A simulation's sensor samples as a rosbag2 bag (what `storey simulate` and `storey map`
// write for a simulated building).
#pragma once

#include <string>

#include "storey/bag/metadata.h"
#include "storey/sim/simulator.h"

namespace storey::tools {

// Every robot's samples in one bag, interleaved by time (scan, odom, pressure, imu at a
// tie), topics /<robot>/scan, odom, pressure, imu; `storage` bag::kStorageSqlite3 or
// kStorageMcap.
void writeSimulationBag(const sim::Simulation& run, const std::string& folder,
                        const std::string& storage = bag::kStorageSqlite3);

}  // namespace storey::tools
