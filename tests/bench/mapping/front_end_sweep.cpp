// bench_front_end: the per-floor front end on every log of ../shared/data/carmen under the
// conditions real robots and recordings produce, seeds 1-3, one table.
//
//   bench_front_end [--config FILE] [--seeds 1,2,3] [--jobs N] [--filter A|B|...] [--half
//   tuning|checking]
//                   [--csv FILE] [--maps DIR] [--trace DIR]
//
// A cell is one log, one condition and one seed. Conditions: the scan spacing (every scan;
// thinned to 0.5 m / 0.5 rad; 1 m / 1 rad), crossed with either an odometry condition
// (noise 2 %/1°, 5 %/2°, 10 %/5° per metre; a wheel radius 3 % large with 1°/m heading
// drift; stalls) with the laser as logged, or a laser condition (ranges cut at 3.5 m or
// 8 m, every other beam, 3 cm range noise, 180° field of view) with 5 %/2° odometry. The
// GMapping log of csail keeps its recorded odometry, so only spacing and laser vary there.
// Goals per cell (docs/floor_mapper.md, "Robustness benchmark"): nearby relation error
// <= 0.03 m and 0.5°, pairs more than 10 m apart <= 0.5 m, no scan rejected, and at least
// 50x real time on one core (CPU time of the cell's thread). Reference poses that their
// own scans contradict are left out of the errors (storey::eval::checkReferencePoses). A 180°
// view is not run on a log whose laser sees no more than that (the shared logs' lasers
// see 180°): it would repeat the logged laser's cells.
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/floor/floor_graph.h"
#include "storey/grid/image.h"
#include "storey/io/carmen.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_slam.h"

namespace {

using storey::geometry::Pose2;
namespace mapping = storey::mapping;

constexpr double kDeg = M_PI / 180.0;

struct LogSpec {
  std::string name;
  std::string file;       // under carmen/
  std::string reference;  // another log's poses as the reference ("" : its own)
  bool recorded_odometry = false;
  std::string half;  // "tuning" or "checking"
};

// The tuning half chooses defaults; the checking half is only reported. csail's two logs hold
// the same scans, so they share a half.
const std::vector<LogSpec> kLogs = {
    {"intel", "intel-corrected.log.gz", "", false, "tuning"},
    {"freiburg-079", "freiburg-079-corrected.log.gz", "", false, "tuning"},
    {"infinite-corridor", "infinite-corridor-corrected.log.gz", "", false, "tuning"},
    {"csail", "csail-corrected.log.gz", "", false, "checking"},
    {"csail-gfs", "csail.corrected.gfs.gz", "csail-corrected.log.gz", true, "checking"},
    {"freiburg-101", "freiburg-101-corrected.log.gz", "", false, "checking"},
};

struct Condition {
  std::string spacing, odometry, laser;
  double thin_translation = 0.0, thin_rotation = 0.0;
  storey::eval::OdometryNoise noise;
  storey::eval::LaserDegradation degradation;
  std::string name() const { return spacing + " " + odometry + " " + laser; }
};

std::vector<Condition> conditions(bool recorded_odometry) {
  struct Spacing {
    std::string name;
    double t, r;
  };
  const std::vector<Spacing> spacings = {{"every", 0.0, 0.0}, {"0.5m", 0.5, 0.5}, {"1m", 1.0, 1.0}};
  auto noise = [](double t, double r_deg, double fraction) {
    storey::eval::OdometryNoise n;
    n.translation_fraction = t;
    n.rotation_per_meter = r_deg * kDeg;
    n.rotation_fraction = fraction;
    return n;
  };
  std::vector<std::pair<std::string, storey::eval::OdometryNoise>> odometry = {
      {"odo2%/1", noise(0.02, 1.0, 0.01)},
      {"odo5%/2", noise(0.05, 2.0, 0.02)},
      {"odo10%/5", noise(0.10, 5.0, 0.05)}};
  storey::eval::OdometryNoise systematic = noise(0.02, 1.0, 0.01);
  systematic.scale = 1.03;
  systematic.heading_drift_per_meter = 1.0 * kDeg;
  odometry.emplace_back("systematic", systematic);
  // About 2 s of a robot at 0.5 m/s held every 8 m, then caught up at once.
  storey::eval::OdometryNoise stalls = noise(0.05, 2.0, 0.02);
  stalls.stall_every = 8.0;
  stalls.stall_length = 1.0;
  odometry.emplace_back("stalls", stalls);
  auto laser = [](double range, std::size_t step, double noise_m, double fov) {
    storey::eval::LaserDegradation d;
    d.max_range = range;
    d.beam_step = step;
    d.range_noise = noise_m;
    d.field_of_view = fov;
    return d;
  };
  const std::vector<std::pair<std::string, storey::eval::LaserDegradation>> lasers = {
      {"range3.5", laser(3.5, 1, 0, 0)},
      {"range8", laser(8.0, 1, 0, 0)},
      {"half-beams", laser(0, 2, 0, 0)},
      {"noise3cm", laser(0, 1, 0.03, 0)},
      {"fov180", laser(0, 1, 0, M_PI)}};
  std::vector<Condition> out;
  for (const Spacing& s : spacings) {
    const std::string base_odometry = recorded_odometry ? "recorded" : "odo5%/2";
    if (recorded_odometry) {
      out.push_back({s.name, base_odometry, "logged", s.t, s.r, {}, {}});
    } else {
      for (const auto& [name, n] : odometry)
        out.push_back({s.name, name, "logged", s.t, s.r, n, {}});
    }
    for (const auto& [name, d] : lasers)
      out.push_back({s.name, base_odometry, name, s.t, s.r, noise(0.05, 2.0, 0.02), d});
  }
  return out;
}

struct LogData {
  const LogSpec* spec = nullptr;
  std::vector<storey::sensor::LaserScan> scans;
  std::vector<Pose2> poses;        // the reference
  std::vector<Pose2> recorded;     // the log's own poses (recorded odometry for the .gfs)
  std::vector<bool> contradicted;  // reference poses their own scans contradict
  double duration = 0.0;           // s; 0 when the stamps do not tell
};

std::vector<Pose2> posesOf(const std::vector<storey::io::CarmenLaser>& lasers) {
  std::vector<Pose2> poses;
  for (const auto& l : lasers) poses.push_back(l.robotPose());
  return poses;
}

LogData readLog(const std::string& dir, const LogSpec& spec) {
  storey::io::CarmenReaderOptions options;
  options.strict = false;
  const auto lasers = storey::io::readCarmenLasers(dir + "/" + spec.file, options);
  LogData log;
  log.spec = &spec;
  for (const auto& l : lasers) log.scans.push_back(l.scan);
  log.recorded = posesOf(lasers);
  log.poses = spec.reference.empty()
                  ? log.recorded
                  : posesOf(storey::io::readCarmenLasers(dir + "/" + spec.reference, options));
  if (log.poses.size() < log.scans.size())
    throw std::runtime_error(spec.name + ": the reference has fewer scans than the log");
  log.poses.resize(log.scans.size());
  // Stamps: a few repeat or go backwards in some logs (made monotone), others are unusable
  // (the scan index instead, and no duration).
  std::size_t backwards = 0;
  for (std::size_t i = 1; i < log.scans.size(); ++i)
    backwards += !(log.scans[i].stamp > log.scans[i - 1].stamp);
  if (backwards * 20 < log.scans.size()) {
    for (std::size_t i = 1; i < log.scans.size(); ++i)
      log.scans[i].stamp = std::max(log.scans[i].stamp, log.scans[i - 1].stamp);
    log.duration = log.scans.back().stamp - log.scans.front().stamp;
  } else {
    for (std::size_t i = 0; i < log.scans.size(); ++i) log.scans[i].stamp = static_cast<double>(i);
  }
  for (const auto& check : storey::eval::checkReferencePoses(log.scans, log.poses))
    log.contradicted.push_back(check.contradicted);
  return log;
}

struct CellResult {
  std::string log, half, condition;
  int seed = 0;
  std::size_t scans = 0, nodes = 0, rejected = 0, closures = 0;
  storey::eval::RelationErrors errors;
  double cpu_seconds = 0.0, duration = 0.0;
  std::string failures;  // the goals the cell misses, "" when none
};

double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

CellResult runCell(const LogData& log, const Condition& c, int seed,
                   const mapping::FloorSlamOptions& options, const std::string& maps_dir,
                   const std::string& trace_dir) {
  std::vector<std::size_t> kept;
  if (c.thin_translation > 0.0)
    kept = storey::eval::thinnedIndices(log.poses, c.thin_translation, c.thin_rotation);
  else
    for (std::size_t i = 0; i < log.scans.size(); ++i) kept.push_back(i);
  std::vector<storey::sensor::LaserScan> scans;
  std::vector<Pose2> reference, recorded;
  std::vector<bool> left_out;
  std::mt19937_64 rng(static_cast<std::uint64_t>(seed) * 7919u + 17u);
  for (std::size_t i : kept) {
    scans.push_back(storey::eval::degradeScan(log.scans[i], c.degradation, rng));
    reference.push_back(log.poses[i]);
    recorded.push_back(log.recorded[i]);
    left_out.push_back(log.contradicted[i]);
  }
  const std::vector<Pose2> odometry =
      log.spec->recorded_odometry
          ? recorded
          : storey::eval::simulateOdometry(reference, c.noise, static_cast<std::uint64_t>(seed));
  CellResult r;
  r.log = log.spec->name;
  r.half = log.spec->half;
  r.condition = c.name();
  r.seed = seed;
  r.scans = scans.size();
  r.duration = log.duration;
  mapping::FloorSlam slam(options, "robot", 0, 0, 0.0);
  const double start = threadCpuSeconds();
  const storey::eval::OfflineRun run = storey::eval::runOffline(slam, scans, odometry);
  r.cpu_seconds = threadCpuSeconds() - start;
  r.nodes = slam.floorGraph().nodes.size();
  r.rejected = slam.stats().rejected;
  r.closures = slam.stats().loop_closures;
  std::vector<Pose2> estimate;
  for (const auto& p : run.trajectory) estimate.push_back(odometry.front() * p);
  r.errors = storey::eval::relationErrors(estimate, reference, 10.0, 5000, 1, left_out);
  std::ostringstream f;
  if (r.errors.nearby.translation_mean > 0.03) f << " nearby-m";
  if (r.errors.nearby.rotation_mean > 0.5 * kDeg) f << " nearby-deg";
  if (r.errors.far.translation_mean > 0.5) f << " far-m";
  if (r.rejected > 0) f << " rejected";
  if (r.duration > 0.0 && r.duration / r.cpu_seconds < 50.0) f << " speed";
  r.failures = f.str();
  if (!trace_dir.empty()) {
    // Per scan: how it was tracked, and its step's error against the reference.
    std::string file = r.log + "_" + c.spacing + "_" + c.odometry + "_" + c.laser + "_s" +
                       std::to_string(seed) + ".csv";
    std::replace(file.begin(), file.end(), '/', '-');
    std::replace(file.begin(), file.end(), '%', 'p');
    std::ofstream trace(trace_dir + "/" + file);
    trace << "scan,status,matched,score,caught_up,odometry_agrees,step_error_m,step_error_deg,"
             "odometry_error_m\n";
    for (std::size_t i = 0; i < run.results.size(); ++i) {
      const mapping::ScanResult& s = run.results[i];
      trace << i << ',' << mapping::scanStatusName(s.status) << ',' << s.matched << ',' << s.score
            << ',' << s.caught_up << ',' << s.odometry_agrees << ',';
      if (i > 0) {
        const Pose2 e =
            reference[i - 1].between(reference[i]).between(estimate[i - 1].between(estimate[i]));
        const Pose2 o =
            reference[i - 1].between(reference[i]).between(odometry[i - 1].between(odometry[i]));
        trace << e.translation().norm() << ',' << std::abs(e.theta()) / kDeg << ','
              << o.translation().norm();
      } else {
        trace << ",,";
      }
      trace << '\n';
    }
  }
  if (!maps_dir.empty()) {
    storey::grid::OccupancyGridOptions grid_options;
    grid_options.resolution = 0.1;
    std::string file = r.log + "_" + c.spacing + "_" + c.odometry + "_" + c.laser + "_s" +
                       std::to_string(seed) + ".png";
    std::replace(file.begin(), file.end(), '/', '-');
    std::replace(file.begin(), file.end(), '%', 'p');
    storey::grid::writePng(
        maps_dir + "/" + file,
        storey::grid::renderGrey(storey::floor::renderFloorMap(slam.floorGraph(), grid_options)));
  }
  return r;
}

std::vector<int> parseSeeds(const std::string& text) {
  std::vector<int> seeds;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) seeds.push_back(std::stoi(item));
  return seeds;
}

// Whether "log spacing odometry laser" contains any of the '|'-separated parts of `filter`
// (everything matches an empty filter).
bool matchesFilter(const std::string& label, const std::string& filter) {
  if (filter.empty()) return true;
  std::stringstream in(filter);
  std::string part;
  while (std::getline(in, part, '|'))
    if (!part.empty() && label.find(part) != std::string::npos) return true;
  return false;
}

void printRow(std::FILE* out, const CellResult& r) {
  const auto& e = r.errors;
  const std::string rt =
      r.duration > 0.0 ? std::to_string(static_cast<int>(r.duration / r.cpu_seconds)) : "-";
  std::fprintf(
      out, "%-18s %-8s %-30s %4d %5zu %5zu %4zu %4zu  %.4f %6.3f %7.3f  %7.2f %5s %6.0f  %s\n",
      r.log.c_str(), r.half.c_str(), r.condition.c_str(), r.seed, r.scans, r.nodes, r.rejected,
      r.closures, e.nearby.translation_mean, e.nearby.rotation_mean / kDeg, e.far.translation_mean,
      r.cpu_seconds, rt.c_str(), static_cast<double>(r.scans) / std::max(1e-9, r.cpu_seconds),
      r.failures.empty() ? "ok" : r.failures.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string config = std::string(STOREY_SOURCE_DIR) + "/config/floor_mapper.yaml";
  std::string data = std::string(STOREY_SOURCE_DIR) + "/../shared/data/carmen";
  std::string seeds_text = "1,2,3", filter, half, csv_path, maps_dir, trace_dir;
  int jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--config")
      config = value();
    else if (a == "--data")
      data = value();
    else if (a == "--seeds")
      seeds_text = value();
    else if (a == "--jobs")
      jobs = std::stoi(value());
    else if (a == "--filter")
      filter = value();
    else if (a == "--half")
      half = value();
    else if (a == "--csv")
      csv_path = value();
    else if (a == "--maps")
      maps_dir = value();
    else if (a == "--trace")
      trace_dir = value();
    else {
      std::cerr << "usage: bench_front_end [--config FILE] [--data DIR] [--seeds 1,2,3] [--jobs N] "
                   "[--filter A|B|...] [--half tuning|checking] [--csv FILE] [--maps DIR] [--trace "
                   "DIR]\n";
      return a == "--help" ? 0 : 2;
    }
  }
  storey::common::setLogLevel(storey::common::LogLevel::kError);
  if (!std::filesystem::exists(data)) {
    std::printf("bench_front_end: %s is absent; nothing to run\n", data.c_str());
    return 0;
  }
  if (!maps_dir.empty()) std::filesystem::create_directories(maps_dir);
  if (!trace_dir.empty()) std::filesystem::create_directories(trace_dir);
  const mapping::FloorSlamOptions options =
      mapping::readFloorSlamOptions(storey::common::ConfigNode::loadFile(config).child("slam"));
  const std::vector<int> seeds = parseSeeds(seeds_text);

  struct Job {
    const LogSpec* spec;
    Condition condition;
    int seed;
  };
  std::vector<Job> queue;
  std::map<std::string, LogData> logs;
  for (const LogSpec& spec : kLogs) {
    if (!half.empty() && spec.half != half) continue;
    for (const Condition& c : conditions(spec.recorded_odometry))
      for (int seed : seeds) {
        const std::string label = spec.name + " " + c.name();
        if (!matchesFilter(label, filter)) continue;
        if (!logs.count(spec.name)) logs.emplace(spec.name, readLog(data, spec));
        // A view no wider than the logged one is the logged laser: not run twice.
        const storey::sensor::LaserScan& first = logs.at(spec.name).scans.front();
        const double fov = first.angle_increment * static_cast<double>(first.size() - 1);
        if (c.degradation.field_of_view > 0.0 && fov <= c.degradation.field_of_view + 1e-6)
          continue;
        queue.push_back({&spec, c, seed});
      }
  }

  std::printf("bench_front_end: %zu cells, %d jobs, config %s\n", queue.size(), jobs,
              config.c_str());
  std::printf("%-18s %-8s %-30s %4s %5s %5s %4s %4s  %-6s %6s %7s  %7s %5s %6s  %s\n", "log",
              "half", "spacing odometry laser", "seed", "scans", "nodes", "rej", "clos", "near_m",
              "near_d", "far_m", "cpu_s", "rt_x", "scan/s", "goals missed");
  std::vector<CellResult> results(queue.size());
  std::atomic<std::size_t> next{0};
  std::mutex print_mutex;
  std::vector<std::thread> workers;
  for (int w = 0; w < std::max(1, jobs); ++w)
    workers.emplace_back([&] {
      for (std::size_t k = next++; k < queue.size(); k = next++) {
        results[k] = runCell(logs.at(queue[k].spec->name), queue[k].condition, queue[k].seed,
                             options, maps_dir, trace_dir);
        std::lock_guard<std::mutex> lock(print_mutex);
        printRow(stdout, results[k]);
        std::fflush(stdout);
      }
    });
  for (auto& w : workers) w.join();

  if (!csv_path.empty()) {
    std::ofstream csv(csv_path);
    csv << "log,half,spacing,odometry,laser,seed,scans,nodes,rejected,closures,nearby_m,nearby_deg,"
           "far_m,far_deg,"
           "cpu_s,duration_s,failures\n";
    for (std::size_t k = 0; k < results.size(); ++k) {
      const CellResult& r = results[k];
      const Condition& c = queue[k].condition;
      csv << r.log << ',' << r.half << ',' << c.spacing << ',' << c.odometry << ',' << c.laser
          << ',' << r.seed << ',' << r.scans << ',' << r.nodes << ',' << r.rejected << ','
          << r.closures << ',' << r.errors.nearby.translation_mean << ','
          << r.errors.nearby.rotation_mean / kDeg << ',' << r.errors.far.translation_mean << ','
          << r.errors.far.rotation_mean / kDeg << ',' << r.cpu_seconds << ',' << r.duration << ','
          << r.failures << '\n';
    }
  }
  // Summary per half: cells meeting every goal, and the cells that do not.
  for (const std::string h : {"tuning", "checking"}) {
    std::size_t total = 0, met = 0;
    double worst_far = 0.0;
    for (const CellResult& r : results)
      if (r.half == h) {
        ++total;
        met += r.failures.empty();
        worst_far = std::max(worst_far, r.errors.far.translation_mean);
      }
    if (total == 0) continue;
    std::printf("\n%s half: %zu of %zu cells meet every goal (worst far error %.2f m)\n", h.c_str(),
                met, total, worst_far);
    for (const CellResult& r : results)
      if (r.half == h && !r.failures.empty()) printRow(stdout, r);
  }
  return 0;
}
