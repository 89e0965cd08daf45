// `storey map` when a ride's height is unknown: a robot without a barometer whose IMU is
// silent for a while. The floor it is on after the gap is found by localising the scans
// that follow in the known floors' maps, and the building is as without the gap.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "storey/eval/corridors.h"
#include "storey/eval/metrics.h"
#include "storey/eval/trajectory.h"
#include "storey/sim/ground_truth.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/map_job.h"
#include "storey/tools/simulation_bag.h"
#include "test_support.h"

namespace storey::tools {
namespace {
namespace fs = std::filesystem;

// office4 (floors alike around the elevator, different elsewhere) without a barometer;
// no IMU samples in the gaps (s after the start of ride `ride`, or of the recording when
// `ride` is negative).
eval::Evaluation mapWithImuGaps(int ride, const std::vector<std::pair<double, double>>& gaps,
                                int domain) {
  const std::string dir = test::makeTempDir("storey_map_imu_gap");
  sim::SimulateOptions so;
  so.seed = 1;
  so.without_barometer = true;
  sim::Simulation run = sim::simulate(
      sim::loadScenario((fs::path(defaultConfigDir()) / "buildings" / "office4.yaml").string()),
      so);
  auto& robot = run.robots.at(0);
  const double origin = ride >= 0 ? robot.transits.at(static_cast<std::size_t>(ride)).start : 0.0;
  auto& imu = robot.imu;
  for (const auto& [from, to] : gaps)
    imu.erase(std::remove_if(imu.begin(), imu.end(),
                             [&](const sensor::ImuSample& s) {
                               return s.stamp > origin + from && s.stamp < origin + to;
                             }),
              imu.end());
  writeSimulationBag(run, dir + "/bag");
  sim::writeGroundTruth(run, dir + "/truth");
  MapJobOptions options;
  options.domain_id = domain;
  options.output_dir = dir + "/out";
  options.quiet = true;
  options.inputs = {parseMapInput(dir + "/bag")};
  runMapJob(options);
  const auto estimate = eval::readTrajectoryCsv(dir + "/out/trajectory.csv");
  const auto truth = eval::readTrajectoryCsv(dir + "/truth/trajectory.csv");
  // Every pose on the right floor: one estimated floor per true floor, and the other way round.
  std::map<double, std::string> truth_floor;
  for (const auto& row : truth) truth_floor[row.stamp] = row.floor;
  std::map<std::string, std::set<std::string>> estimated_of, true_of;
  std::size_t checked = 0;
  for (const auto& row : estimate) {
    const auto it = truth_floor.find(row.stamp);
    if (it == truth_floor.end()) continue;
    ++checked;
    estimated_of[it->second].insert(row.floor);
    true_of[row.floor].insert(it->second);
  }
  EXPECT_GT(checked, estimate.size() / 2);
  EXPECT_EQ(estimated_of.size(), run.building.floors.size());
  for (const auto& [floor, estimated] : estimated_of)
    EXPECT_EQ(estimated.size(), 1u) << "true floor " << floor;
  for (const auto& [floor, real] : true_of)
    EXPECT_EQ(real.size(), 1u) << "estimated floor " << floor;
  return eval::evaluate(estimate, truth, eval::readCorridors(dir + "/truth/corridors.yaml"));
}

void expectEveryFloorPlaced(const eval::Evaluation& e) {
  ASSERT_FALSE(e.floors.empty());
  for (const auto& floor : e.floors) {
    EXPECT_LT(floor.residual_translation, 0.05) << floor.floor;
    EXPECT_LT(floor.residual_rotation * 180 / M_PI, 0.2) << floor.floor;
  }
}

TEST(MapJobIdentity, AReturnToAKnownFloorDuringAnImuGapIsFoundByItsMap) {
  // F3 -> F2 down the stairs (38 s), the IMU silent for 20 s of it: the height change is
  // unknown, and F2 is found in its map among F0..F3 (alike around the elevator).
  expectEveryFloorPlaced(mapWithImuGaps(3, {{10.0, 30.0}}, 67));
}

TEST(MapJobIdentity, ImuGapsOnAFloorKeepTheFloor) {
  // Three 3 s gaps while the robot drives on F0, F1 and F2: each is a ride the IMU could
  // have missed, and each floor's map says it was not.
  expectEveryFloorPlaced(mapWithImuGaps(-1, {{100.0, 103.0}, {300.0, 303.0}, {450.0, 453.0}}, 68));
}

}  // namespace
}  // namespace storey::tools
