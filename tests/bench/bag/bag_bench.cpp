// Bag throughput: writing and reading raw messages of several sizes, and LaserScans through
// CDR + SensorBagWriter/Reader, in sqlite3 storage (the reference) and MCAP (second
// argument 1). Each iteration writes (or reads) a whole bag in a fresh temporary folder on
// the local disk. Rates are per wall-clock second (UseRealTime); file_MB is the bag's size.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "storey/runtime/sensor_bag.h"

namespace {

namespace fs = std::filesystem;

const fs::path& benchRoot() {
  static const fs::path root = [] {
    std::string pattern = (fs::temp_directory_path() / "storey_bag_bench_XXXXXX").string();
    if (!mkdtemp(pattern.data())) std::abort();
    return fs::path(pattern);
  }();
  return root;
}

std::string freshFolder(const std::string& name) {
  const fs::path folder = benchRoot() / name;
  fs::remove_all(folder);
  return folder.string();
}

constexpr int kMessages = 20000;

storey::bag::BagWriterOptions storage(const benchmark::State& state) {
  storey::bag::BagWriterOptions options;
  options.storage = state.range(1) ? storey::bag::kStorageMcap : storey::bag::kStorageSqlite3;
  return options;
}

double megabytes(const std::string& folder) {
  std::uintmax_t bytes = 0;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file()) bytes += entry.file_size();
  return static_cast<double>(bytes) / 1e6;
}

void writeRaw(const std::string& folder, std::size_t size,
              const storey::bag::BagWriterOptions& options) {
  std::vector<std::uint8_t> bytes(size);
  std::mt19937 rng(1);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
  storey::bag::BagWriter writer(folder, options);
  writer.createTopic({"/robot/scan", "sensor_msgs/msg/LaserScan", "cdr", ""});
  for (int i = 0; i < kMessages; ++i) {
    bytes[0] = static_cast<std::uint8_t>(i);
    writer.write("/robot/scan", 1'000'000'000LL + i * 25'000'000LL, bytes);
  }
  writer.close();
}

void BM_WriteRaw(benchmark::State& state) {
  const auto size = static_cast<std::size_t>(state.range(0));
  const std::string folder = freshFolder("write");
  for (auto _ : state) writeRaw(freshFolder("write"), size, storage(state));
  state.SetLabel(storage(state).storage);
  state.counters["file_MB"] = megabytes(folder);
  state.SetItemsProcessed(state.iterations() * kMessages);
  state.SetBytesProcessed(state.iterations() * kMessages * static_cast<int64_t>(size));
}
BENCHMARK(BM_WriteRaw)
    ->ArgsProduct({{100, 1500, 16000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_ReadRaw(benchmark::State& state) {
  const auto size = static_cast<std::size_t>(state.range(0));
  const std::string folder = freshFolder("read" + std::to_string(size));
  writeRaw(folder, size, storage(state));
  state.SetLabel(storage(state).storage);
  for (auto _ : state) {
    storey::bag::BagReader reader(folder);
    storey::bag::BagMessage message;
    std::size_t bytes = 0;
    while (reader.next(message)) bytes += message.data.size();
    if (bytes != kMessages * size) state.SkipWithError("short read");
  }
  state.SetItemsProcessed(state.iterations() * kMessages);
  state.SetBytesProcessed(state.iterations() * kMessages * static_cast<int64_t>(size));
}
BENCHMARK(BM_ReadRaw)
    ->ArgsProduct({{100, 1500, 16000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

storey::sensor::LaserScan makeScan(int beams) {
  storey::sensor::LaserScan scan;
  scan.angle_min = -M_PI;
  scan.angle_increment = 2 * M_PI / beams;
  scan.range_max = 30.0;
  scan.ranges.resize(static_cast<std::size_t>(beams));
  for (int i = 0; i < beams; ++i) scan.ranges[i] = 1.0f + 0.01f * static_cast<float>(i % 500);
  return scan;
}

constexpr int kScans = 5000;

void writeScans(const std::string& folder, int beams,
                const storey::bag::BagWriterOptions& options) {
  storey::sensor::LaserScan scan = makeScan(beams);
  storey::runtime::SensorBagWriter writer(folder, options);
  for (int i = 0; i < kScans; ++i) {
    scan.stamp = 1000.0 + 0.025 * i;
    writer.write("robot", scan);
  }
  writer.close();
}

void BM_WriteLaserScans(benchmark::State& state) {
  const int beams = static_cast<int>(state.range(0));
  const std::string folder = freshFolder("scans");
  for (auto _ : state) writeScans(freshFolder("scans"), beams, storage(state));
  state.SetLabel(storage(state).storage);
  state.counters["file_MB"] = megabytes(folder);
  state.SetItemsProcessed(state.iterations() * kScans);
  state.SetBytesProcessed(state.iterations() * kScans * (beams * 4 + 60));
}
BENCHMARK(BM_WriteLaserScans)
    ->ArgsProduct({{360, 1081}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_ReadLaserScans(benchmark::State& state) {
  const int beams = static_cast<int>(state.range(0));
  const std::string folder = freshFolder("scans_read" + std::to_string(beams));
  writeScans(folder, beams, storage(state));
  state.SetLabel(storage(state).storage);
  for (auto _ : state) {
    storey::runtime::SensorBagReader reader(folder);
    storey::runtime::SensorRecord record;
    int count = 0;
    while (reader.next(record)) ++count;
    if (count != kScans) state.SkipWithError("short read");
  }
  state.SetItemsProcessed(state.iterations() * kScans);
  state.SetBytesProcessed(state.iterations() * kScans * (beams * 4 + 60));
}
BENCHMARK(BM_ReadLaserScans)
    ->ArgsProduct({{360, 1081}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  fs::remove_all(benchRoot());
  return 0;
}
