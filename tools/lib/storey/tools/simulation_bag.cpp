#include "storey/tools/simulation_bag.h"

#include <algorithm>
#include <limits>
#include <vector>

#include "storey/runtime/sensor_bag.h"

namespace storey::tools {

void writeSimulationBag(const sim::Simulation& run, const std::string& folder,
                        const std::string& storage) {
  bag::BagWriterOptions options;
  options.storage = storage;
  runtime::SensorBagWriter bag(folder, options);
  struct Cursor {
    const sim::RobotRun* robot;
    std::size_t s = 0, o = 0, p = 0, i = 0;
  };
  std::vector<Cursor> cursors;
  for (const auto& robot : run.robots) cursors.push_back({&robot});
  constexpr double kEnd = std::numeric_limits<double>::infinity();
  while (true) {
    // The robot with the earliest next sample, so several robots interleave by time.
    Cursor* best = nullptr;
    double best_stamp = kEnd;
    for (auto& c : cursors) {
      const auto& r = *c.robot;
      const double next = std::min({c.s < r.scans.size() ? r.scans[c.s].stamp : kEnd,
                                    c.o < r.odometry.size() ? r.odometry[c.o].stamp : kEnd,
                                    c.p < r.pressure.size() ? r.pressure[c.p].stamp : kEnd,
                                    c.i < r.imu.size() ? r.imu[c.i].stamp : kEnd});
      if (next < best_stamp) {
        best_stamp = next;
        best = &c;
      }
    }
    if (!best) break;
    const auto& r = *best->robot;
    if (best->s < r.scans.size() && r.scans[best->s].stamp == best_stamp) bag.write(r.name, r.scans[best->s++]);
    else if (best->o < r.odometry.size() && r.odometry[best->o].stamp == best_stamp) bag.write(r.name, r.odometry[best->o++]);
    else if (best->p < r.pressure.size() && r.pressure[best->p].stamp == best_stamp) bag.write(r.name, r.pressure[best->p++]);
    else bag.write(r.name, r.imu[best->i++]);
  }
  bag.close();
}

}  // namespace storey::tools
