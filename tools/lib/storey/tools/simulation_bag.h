// A simulation's sensor samples as a rosbag2 bag (what `storey simulate` and `storey map`
// write for a simulated building).
#pragma once

#include <string>

#include "storey/sim/simulator.h"

namespace storey::tools {

// Every robot's samples in one bag, interleaved by time (scan, odom, pressure, imu at a
// tie), topics /<robot>/scan, odom, pressure, imu.
void writeSimulationBag(const sim::Simulation& run, const std::string& folder);

}  // namespace storey::tools
