// Floor matcher benchmarks. BM_FilterUpdate: the sensor update alone (particles x beams
// against the likelihood field's log p table), as particle-beam evaluations per second.
// BM_MatchBuilding/<scenario>: simulate once, then find all inter-floor constraints
// (threads from config/floor_matcher.yaml, 2), reporting constraints and wrong ones.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "storey/common/config.h"
#include "storey/eval/simulated_floors.h"
#include "storey/localization/particle_filter.h"
#include "storey/matching/floor_matcher.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"

namespace {

using namespace storey;

std::string scenarioPath(const std::string& name) {
  return std::string(STOREY_SOURCE_DIR) + "/config/buildings/" + name + ".yaml";
}

matching::FloorMatcherOptions shippedOptions() {
  const auto root =
      common::ConfigNode::loadFile(std::string(STOREY_SOURCE_DIR) + "/config/floor_matcher.yaml");
  return matching::readFloorMatcherOptions(root.child("floor_matcher"));
}

const eval::SimulatedFloors& floorsOf(const std::string& name) {
  static std::map<std::string, std::unique_ptr<eval::SimulatedFloors>> cache;
  auto& slot = cache[name];
  if (!slot) {
    const sim::Simulation run = sim::simulate(sim::loadScenario(scenarioPath(name)), 1);
    slot = std::make_unique<eval::SimulatedFloors>(
        eval::floorGraphsFromSimulation(run, eval::SimulatedFloorsOptions{}));
  }
  return *slot;
}

void BM_FilterUpdate(benchmark::State& state) {
  const auto& floors = floorsOf("small2");
  const auto& g = floors.graphs.front();
  const matching::FloorMatcherOptions o = shippedOptions();
  const localization::LocalizationMap map(floor::renderFloorMap(g, o.map), o.likelihood_field);
  localization::ParticleFilterOptions fo = o.filter;
  fo.max_particles = static_cast<int>(state.range(0));
  fo.min_particles = fo.max_particles;
  fo.initial_particles_per_m2 = 1e6;  // clamped to max_particles
  localization::ParticleFilter pf(map, fo, 1);
  pf.initializeUniform();
  std::size_t n = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(pf.update(g.nodes[n % g.nodes.size()].scan));
    ++n;
  }
  state.counters["particles"] = static_cast<double>(pf.size());
  state.counters["evaluations/s"] =
      benchmark::Counter(static_cast<double>(pf.beamEvaluations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FilterUpdate)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_MatchBuilding(benchmark::State& state, const std::string& name) {
  if (!std::filesystem::exists(scenarioPath(name))) {
    state.SkipWithError(("scenario " + name + " is not in the tree").c_str());
    return;
  }
  const auto& floors = floorsOf(name);
  const matching::FloorMatcherOptions o = shippedOptions();
  matching::MatchResult result;
  for (auto _ : state) result = matching::matchFloors(floors.graphs, o);
  int wrong = 0;
  for (const auto& c : result.constraints) wrong += eval::judgeConstraint(c, floors).wrong;
  state.counters["floor_graphs"] = static_cast<double>(floors.graphs.size());
  state.counters["constraints"] = static_cast<double>(result.constraints.size());
  state.counters["wrong"] = wrong;
  state.counters["threads"] = o.threads;
  state.counters["evaluations/s"] = static_cast<double>(result.beam_evaluations) / result.seconds;
}
BENCHMARK_CAPTURE(BM_MatchBuilding, small2, std::string("small2"))
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_MatchBuilding, office4, std::string("office4"))
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_MatchBuilding, tower10, std::string("tower10"))
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
