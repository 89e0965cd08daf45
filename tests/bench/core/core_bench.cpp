// Speed of the core's hot paths. Figures, not assertions: see docs/core.md for the
// numbers and the command.
#include <benchmark/benchmark.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "storey/grid/distance_transform.h"
#include "storey/grid/likelihood_field.h"
#include "storey/grid/occupancy_grid.h"
#include "storey/io/carmen.h"

namespace {

using storey::geometry::Pose2;
namespace grid = storey::grid;
namespace io = storey::io;

storey::sensor::LaserScan ringScan(int beams, float range) {
  storey::sensor::LaserScan scan;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / beams;
  scan.range_min = 0.05;
  scan.range_max = 30.0;
  scan.ranges.assign(beams, range);
  return scan;
}

// 360 beams at 10 m into a 5 cm grid, from poses jittered around one spot (the grid is
// already grown, as it is for most scans of a mapping run).
void BM_InsertScan(benchmark::State& state) {
  const auto scan = ringScan(360, 10.0f);
  grid::OccupancyGrid map;
  map.insertScan(scan, Pose2(0, 0, 0));
  // Cells one scan updates (each at most once), counted by comparing before and after.
  const auto before = map.logOdds().data;
  map.insertScan(scan, Pose2(0.013, -0.007, 0.01));
  std::size_t updated = 0;
  for (std::size_t i = 0; i < before.size(); ++i) updated += before[i] != map.logOdds().data[i];
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  for (auto _ : state) {
    map.insertScan(scan, Pose2(jitter(rng), jitter(rng), jitter(rng)));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());  // scans
  state.counters["cells_per_scan"] = static_cast<double>(updated);
  state.counters["cells/s"] = benchmark::Counter(static_cast<double>(updated) * state.iterations(),
                                                 benchmark::Counter::kIsRate);
}
BENCHMARK(BM_InsertScan)->Unit(benchmark::kMicrosecond);

// A 50 m x 50 m floor (1000 x 1000 cells) of rooms: walls every 4 m with door gaps.
std::vector<std::uint8_t> roomsMask(const grid::GridFrame& f) {
  std::vector<std::uint8_t> mask(f.cellCount(), 0);
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const bool wall_x = x % 80 == 0 && (y % 80) > 16, wall_y = y % 80 == 0 && (x % 80) > 16;
      mask[f.index(x, y)] = wall_x || wall_y;
    }
  return mask;
}

grid::GridFrame frameOf(int width, int height) {
  grid::GridFrame f;
  f.resolution = 0.05;
  f.width = width;
  f.height = height;
  return f;
}

const grid::LikelihoodField& roomsField() {
  static const grid::LikelihoodField field = [] {
    const grid::GridFrame f = frameOf(1000, 1000);
    return grid::LikelihoodField(f, roomsMask(f), grid::LikelihoodFieldOptions{});
  }();
  return field;
}

void BM_LikelihoodLookupRandom(benchmark::State& state) {
  const auto& field = roomsField();
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0.0, 50.0);
  std::vector<Eigen::Vector2d> points(1 << 20);
  for (auto& p : points) p = {u(rng), u(rng)};
  for (auto _ : state) {
    float sum = 0;
    for (const auto& p : points) sum += field.logLikelihoodAt(p);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_LikelihoodLookupRandom)->Unit(benchmark::kMillisecond);

// Endpoints of 360-beam scans (10 m) from poses along a path: neighbouring lookups touch
// neighbouring cells, as in scan matching and particle weighting.
void BM_LikelihoodLookupScanOrdered(benchmark::State& state) {
  const auto& field = roomsField();
  const auto scan = ringScan(360, 10.0f);
  std::vector<Eigen::Vector2d> points;
  for (int k = 0; k < 2900; ++k) {
    const Pose2 pose(2 + 0.016 * k, 25 + 5 * std::sin(0.01 * k), 0.002 * k);
    for (const auto& p : scan.pointsInWorld(pose)) points.push_back(p);
  }
  for (auto _ : state) {
    float sum = 0;
    for (const auto& p : points) sum += field.logLikelihoodAt(p);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_LikelihoodLookupScanOrdered)->Unit(benchmark::kMillisecond);

void BM_InterpolatedScoreWithGradient(benchmark::State& state) {
  const auto& field = roomsField();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 50.0);
  std::vector<Eigen::Vector2d> points(1 << 20);
  for (auto& p : points) p = {u(rng), u(rng)};
  for (auto _ : state) {
    double sum = 0;
    Eigen::Vector2d g;
    for (const auto& p : points) sum += field.interpolatedScore(p, &g) + g.x();
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.size()));
}
BENCHMARK(BM_InterpolatedScoreWithGradient)->Unit(benchmark::kMillisecond);

constexpr int kDtSide = 2000;

void BM_DistanceTransform2000(benchmark::State& state) {
  const grid::GridFrame f = frameOf(kDtSide, kDtSide);
  std::vector<std::uint8_t> sources(f.cellCount(), 0);
  std::mt19937_64 rng(4);
  std::bernoulli_distribution pick(0.01);
  for (auto& s : sources) s = pick(rng);
  for (auto _ : state) {
    auto d = grid::squaredDistanceTransform(f, sources);
    benchmark::DoNotOptimize(d.data.data());
  }
  const double cells = static_cast<double>(f.cellCount());
  state.counters["cells/s"] =
      benchmark::Counter(cells * state.iterations(), benchmark::Counter::kIsRate);
  state.SetBytesProcessed(state.iterations() *
                          static_cast<std::int64_t>(f.cellCount() * sizeof(float)));
}
BENCHMARK(BM_DistanceTransform2000)->Unit(benchmark::kMillisecond);

// Walls of 4 m rooms, exact (argument 0) and bounded at 20 cells (the likelihood field's
// 1 m cap at 5 cm: what LikelihoodField asks for), in one run for the ratio.
void BM_DistanceTransformRooms2000(benchmark::State& state) {
  const grid::GridFrame f = frameOf(kDtSide, kDtSide);
  const auto mask = roomsMask(f);
  const int bound = state.range(0) > 0 ? static_cast<int>(state.range(0)) : -1;
  for (auto _ : state) {
    auto d = grid::squaredDistanceTransform(f, mask, bound);
    benchmark::DoNotOptimize(d.data.data());
  }
  state.counters["cells/s"] = benchmark::Counter(
      static_cast<double>(f.cellCount()) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DistanceTransformRooms2000)->Arg(0)->Arg(20)->Unit(benchmark::kMillisecond);

void BM_LikelihoodFieldBuild2000(benchmark::State& state) {
  const grid::GridFrame f = frameOf(kDtSide, kDtSide);
  const auto mask = roomsMask(f);
  for (auto _ : state) {
    grid::LikelihoodField field(f, mask, grid::LikelihoodFieldOptions{});
    benchmark::DoNotOptimize(field.logLikelihood().data.data());
  }
  state.counters["cells/s"] = benchmark::Counter(
      static_cast<double>(f.cellCount()) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LikelihoodFieldBuild2000)->Unit(benchmark::kMillisecond);

// The memory-bandwidth reference: copying the distance transform's output bytes once.
void BM_MemcpyFloatGrid2000(benchmark::State& state) {
  const std::size_t bytes = static_cast<std::size_t>(kDtSide) * kDtSide * sizeof(float);
  std::vector<char> a(bytes, 1), b(bytes, 0);
  for (auto _ : state) {
    std::memcpy(b.data(), a.data(), bytes);
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
  }
  state.counters["cells/s"] = benchmark::Counter(
      static_cast<double>(kDtSide) * kDtSide * state.iterations(), benchmark::Counter::kIsRate);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_MemcpyFloatGrid2000)->Unit(benchmark::kMillisecond);

std::string intelPath() {
  const std::filesystem::path path =
      std::filesystem::path(STOREY_SHARED_DATA_DIR) / "carmen" / "intel-corrected.log.gz";
  return std::filesystem::exists(path) ? path.string() : "";
}

void parseLog(benchmark::State& state, const std::string& path) {
  std::size_t lines = 0, bytes = 0;
  for (auto _ : state) {
    io::CarmenReader reader(path);
    io::CarmenRecord record;
    std::size_t n = 0;
    while (reader.next(&record)) ++n;
    benchmark::DoNotOptimize(n);
    lines += reader.stats().lines;
    bytes += reader.stats().bytes;
  }
  state.counters["lines/s"] =
      benchmark::Counter(static_cast<double>(lines), benchmark::Counter::kIsRate);
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));  // uncompressed text
}

void BM_CarmenParseIntelGzip(benchmark::State& state) {
  const std::string path = intelPath();
  if (path.empty()) {
    state.SkipWithError("../shared/data/carmen/intel-corrected.log.gz is absent");
    return;
  }
  parseLog(state, path);
}
BENCHMARK(BM_CarmenParseIntelGzip)->Unit(benchmark::kMillisecond);

void BM_CarmenParseIntelPlain(benchmark::State& state) {
  const std::string gz = intelPath();
  if (gz.empty()) {
    state.SkipWithError("../shared/data/carmen/intel-corrected.log.gz is absent");
    return;
  }
  // Decompressed once into a temporary file, to separate parsing from inflating.
  const std::string plain =
      (std::filesystem::temp_directory_path() / "storey_bench_intel.log").string();
  {
    gzFile in = gzopen(gz.c_str(), "rb");
    std::ofstream out(plain, std::ios::binary);
    char buffer[1 << 16];
    int n;
    while ((n = gzread(in, buffer, sizeof(buffer))) > 0) out.write(buffer, n);
    gzclose(in);
  }
  parseLog(state, plain);
  std::filesystem::remove(plain);
}
BENCHMARK(BM_CarmenParseIntelPlain)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
