// How fast the simulator produces robot time: one robot touring office4 for an hour
// (3 Hz x 271-beam laser, 20 Hz odometry, 10 Hz barometer, 50 Hz IMU), and the ray caster
// alone against brute force. Prints robot seconds per wall-clock second.
#include <benchmark/benchmark.h>

#include <cmath>

#include "storey/sim/random.h"
#include "storey/sim/ray_caster.h"
#include "storey/sim/simulator.h"

namespace {

using storey::sim::Scenario;

// office4's mission repeated until it lasts well over an hour; simulate() cuts at 3600 s.
const Scenario& hourScenario() {
  static const Scenario scenario = [] {
    Scenario s = storey::sim::loadScenario(STOREY_SOURCE_DIR "/config/buildings/office4.yaml");
    auto& mission = s.robots[0].mission;
    const auto once = mission;
    for (int i = 0; i < 5; ++i) mission.insert(mission.end(), once.begin(), once.end());
    return s;
  }();
  return scenario;
}

void BM_SimulateOneRobotHour(benchmark::State& state) {
  const Scenario& scenario = hourScenario();
  storey::sim::SimulateOptions options;
  options.seed = 7;
  options.max_duration = 3600.0;
  std::size_t scans = 0, beams = 0;
  double robot_seconds = 0.0;
  for (auto _ : state) {
    const auto run = storey::sim::simulate(scenario, options);
    const auto& robot = run.robots[0];
    scans = robot.scans.size();
    beams = scans * robot.scans[0].size();
    robot_seconds = robot.truth.back().stamp - robot.truth.front().stamp;
    benchmark::DoNotOptimize(robot.scans.back().ranges.data());
  }
  state.counters["robot_s"] = robot_seconds;
  state.counters["scans"] = static_cast<double>(scans);
  state.counters["robot_s_per_s"] =
      benchmark::Counter(robot_seconds * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["beams_per_s"] = benchmark::Counter(
      static_cast<double>(beams) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateOneRobotHour)->Unit(benchmark::kMillisecond)->Iterations(3);

// Rays through office4's ground floor from random points in the corridor.
template <bool kGrid>
void BM_CastRays(benchmark::State& state) {
  const Scenario& scenario = hourScenario();
  const storey::sim::RayCaster caster(storey::sim::floorObstacles(scenario.building, 0));
  storey::sim::Rng rng(3);
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> rays;
  for (int i = 0; i < 4096; ++i) {
    const double angle = rng.uniform(0.0, 6.283185307179586);
    rays.push_back(
        {{rng.uniform(1.0, 29.0), rng.uniform(7.3, 8.7)}, {std::cos(angle), std::sin(angle)}});
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& ray = rays[i++ & 4095];
    benchmark::DoNotOptimize(kGrid ? caster.cast(ray.first, ray.second, 30.0)
                                   : caster.castBruteForce(ray.first, ray.second, 30.0));
  }
  state.counters["segments"] = static_cast<double>(caster.segments().size());
}
BENCHMARK_TEMPLATE(BM_CastRays, true)->Name("BM_CastRays/grid");
BENCHMARK_TEMPLATE(BM_CastRays, false)->Name("BM_CastRays/brute_force");

}  // namespace

BENCHMARK_MAIN();
