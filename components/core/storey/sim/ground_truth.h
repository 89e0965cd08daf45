// Ground truth of a simulation on disk (see docs/simulator.md):
//   <dir>/trajectory.csv  stamp,robot,floor,x,y,theta,z at every scan (building frame)
//   <dir>/floors.yaml     floor ids, heights and true floor frames in the building frame
//   <dir>/transits.csv    robot,start,end,from_floor,to_floor,mode
//   <dir>/corridors.yaml  named distances for the evaluator (building frame)
#pragma once

#include <string>

#include "storey/sim/simulator.h"

namespace storey::sim {

// Writes the four files into `dir` (created if missing). Throws std::runtime_error on I/O
// failure naming the file.
void writeGroundTruth(const Simulation& simulation, const std::string& dir);

// A dead-reckoning baseline in the same trajectory.csv format: each robot's odometry,
// interpolated at its scan stamps and placed in the building frame at the true start pose
// (floor and z copied from the truth). What a mapper must beat; writes <dir>/trajectory.csv.
void writeOdometryBaseline(const Simulation& simulation, const std::string& dir);

}  // namespace storey::sim
