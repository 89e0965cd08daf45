// The bad-input suite: one table of input -> command -> expected outcome, for every kind of
// file storey reads, run through the storey executable. Each row is a test of its own.
// Every command must exit (no hang: killed after kTimeout), not by a signal (no crash),
// with the expected status and a message holding the expected text, and its peak memory
// must stay under kMaxResident. A row that expects success also checks what was written.
// docs/bad_input.md describes the rows.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "storey/building/journal.h"
#include "test_support.h"

namespace storey {
namespace {

namespace fs = std::filesystem;

constexpr double kTimeout = 60.0;               // s
constexpr long kMaxResidentKb = 1024L * 1024L;  // 1 GiB
constexpr int kFailure = 1, kUsage = 2, kSuccess = 0;

struct Outcome {
  bool exited = false;
  int status = -1;
  long max_resident_kb = 0;
  double seconds = 0.0;
  std::string output;
};

// Runs argv (no shell: the peak memory measured is the command's own) with `env` set.
Outcome run(const std::vector<std::string>& argv, const std::vector<std::string>& env,
            const std::string& log) {
  Outcome o;
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    FILE* out = std::fopen(log.c_str(), "w");
    if (out) {
      dup2(fileno(out), 1);
      dup2(fileno(out), 2);
    }
    for (const auto& e : env) putenv(const_cast<char*>(e.c_str()));
    std::vector<char*> args;
    args.reserve(argv.size() + 1);
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, WNOHANG, &usage) == 0) {
    if (std::chrono::steady_clock::now() - start > std::chrono::duration<double>(kTimeout)) {
      kill(pid, SIGKILL);
      wait4(pid, &status, 0, &usage);
      o.output = "(killed after the time limit)";
      return o;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  o.exited = WIFEXITED(status);
  o.status = o.exited ? WEXITSTATUS(status) : -WTERMSIG(status);
  o.max_resident_kb = usage.ru_maxrss;
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  o.output = text.str();
  return o;
}

void fifo(const std::string& path) {
  fs::create_directories(fs::path(path).parent_path());
  ASSERT_EQ(mkfifo(path.c_str(), 0600), 0) << path;
}

building::FloorGraphDelta delta(int node, double height = 0.0) {
  building::FloorGraphDelta d;
  d.robot = "r";
  d.graph_id = 1;
  d.floor_height = height;
  d.sequence = static_cast<std::uint32_t>(node);
  floor::FloorNode n;
  n.id = node;
  n.stamp = node;
  n.pose = geometry::Pose2(node, 0, 0);
  n.scan.angle_min = -1.5;
  n.scan.angle_increment = 0.1;
  n.scan.range_max = 20;
  n.scan.ranges.assign(31, 3.0f);
  d.new_nodes.push_back(n);
  if (node > 0) {
    floor::FloorEdge e;
    e.from = node - 1;
    e.to = node;
    e.measurement = geometry::Pose2(1, 0, 0);
    e.information = Eigen::Matrix3d::Identity() * 100.0;
    d.new_edges.push_back(e);
  }
  return d;
}

// A journal of `count` floor-graph records; returns where each record starts.
std::vector<std::uint64_t> journal(const std::string& path, int count, double height = 0.0) {
  fs::create_directories(fs::path(path).parent_path());
  std::vector<std::uint64_t> offsets;
  building::JournalWriter writer(path, false);
  for (int i = 0; i < count; ++i) {
    offsets.push_back(fs::exists(path) ? fs::file_size(path) : 8);
    writer.append(delta(i, i == 2 ? height : 0.0));
  }
  return offsets;
}

const char* const kFlaser = "FLASER 5 1.0 1.1 1.2 1.3 1.4 0 0 0 0 0 0 1 h 1\n";
std::string flaser(double x, double stamp) {
  std::ostringstream out;
  out << "FLASER 5 1.0 1.1 1.2 1.3 1.4 " << x << " 0 0 " << x << " 0 0 " << stamp << " h " << stamp
      << "\n";
  return out.str();
}

// A building file beside a copy of the shipped robot model, as `storey simulate` expects.
std::string building(const std::string& dir, const std::string& outer_wall,
                     const std::string& extra = "") {
  std::string text = test::readFile(test::sourceDir() + "/config/buildings/small2.yaml");
  const std::string wall = "{id: outer, rect: [[0.0, 0.0], [20.0, 12.0]]}";
  text.replace(text.find(wall), wall.size(), outer_wall);
  text.replace(text.find("name: small2\n"), 13, "name: small2\n" + extra);
  test::writeFile(dir + "/robots/default.yaml",
                  test::readFile(test::sourceDir() + "/config/robots/default.yaml"));
  test::writeFile(dir + "/buildings/b.yaml", text);
  return dir + "/buildings/b.yaml";
}

struct Row {
  std::string name;
  // Writes the input into `dir` and returns the command's arguments after `storey`.
  std::function<std::vector<std::string>(const std::string& dir)> setup;
  int status;
  std::string expected;  // in the output
  // For rows that succeed: checks what was written (empty: nothing to check).
  std::function<void(const std::string& dir)> check = {};
  std::vector<std::string> env = {};
};

std::vector<Row> rows() {
  using Args = std::vector<std::string>;
  return {
      // Graph server journals (storey export, storey journal).
      {"JournalIsADirectory",
       [](const std::string& d) {
         fs::create_directories(d + "/j");
         return Args{"export", d + "/j", d + "/out"};
       },
       kFailure, "/j: a directory, not a journal"},
      {"JournalIsADevice",
       [](const std::string& d) {
         return Args{"export", "/dev/zero", d + "/out"};
       },
       kFailure, "/dev/zero: a character device, not a journal"},
      {"JournalIsAFifo",
       [](const std::string& d) {
         fifo(d + "/j.bin");
         return Args{"journal", "check", d + "/j.bin"};
       },
       kFailure, "j.bin: a FIFO, not a journal or input log"},
      {"JournalIsText",
       [](const std::string& d) {
         test::writeFile(d + "/j.bin", "STOREYJ? hello");
         return Args{"export", d + "/j.bin", d + "/out"};
       },
       kFailure, "not a storey journal"},
      {"JournalLengthDamagedInTheMiddle",
       [](const std::string& d) {
         const auto at = journal(d + "/j.bin", 6);
         std::fstream f(d + "/j.bin", std::ios::in | std::ios::out | std::ios::binary);
         f.seekp(static_cast<std::streamoff>(at[2] + 4));
         const std::uint32_t huge = 1u << 24;
         f.write(reinterpret_cast<const char*>(&huge), 4);
         return Args{"export", d + "/j.bin", d + "/out"};
       },
       kFailure, "damaged journal record at offset"},
      {"JournalChecksumDamagedInTheMiddle",
       [](const std::string& d) {
         const auto at = journal(d + "/j.bin", 6);
         std::fstream f(d + "/j.bin", std::ios::in | std::ios::out | std::ios::binary);
         f.seekp(static_cast<std::streamoff>(at[3] + 30));
         f.put('\x55');
         return Args{"journal", "check", d + "/j.bin"};
       },
       kFailure, "(fails its checksum), after 3 intact records"},
      {"JournalTornTail",
       [](const std::string& d) {
         journal(d + "/j.bin", 6);
         fs::resize_file(d + "/j.bin", fs::file_size(d + "/j.bin") - 10);
         return Args{"export", d + "/j.bin", d + "/out"};
       },
       kSuccess, "torn",
       [](const std::string& d) {
         EXPECT_NE(test::readFile(d + "/out/graph.g2o").find("VERTEX_SE2"), std::string::npos);
         // The report's summary says the journal was repaired.
         EXPECT_NE(test::readFile(d + "/out/report.html")
                       .find("<li class=\"warn\">" + d + "/j.bin: the last record was torn"),
                   std::string::npos);
       }},
      {"JournalFloorHeightOutOfReach",
       [](const std::string& d) {
         journal(d + "/j.bin", 4, 1e300);
         return Args{"export", d + "/j.bin", d + "/out"};
       },
       kFailure, "floor height 1e+300 m is not within"},
      {"JournalFloorBeyondTheOctoMap",
       [](const std::string& d) {
         journal(d + "/j.bin", 3, 5000.0);
         return Args{"export", d + "/j.bin", d + "/out"};
       },
       kFailure,
       "reaches 5002.5 m from the origin, beyond the OctoMap's +-3276.8 m at 0.1 m voxels"},
      {"JournalVoxelZero",
       [](const std::string& d) {
         journal(d + "/j.bin", 3);
         return Args{"export", d + "/j.bin", d + "/out", "--voxel", "0"};
       },
       kUsage, "--voxel must lie in [0.01, 5], got 0"},
      {"InputLogTorn",
       [](const std::string& d) {
         std::string log = "STOREYM1";
         const std::uint32_t frame[2] = {0x4A524543, 100};  // record magic, length
         log.append(reinterpret_cast<const char*>(frame), sizeof frame);
         test::writeFile(d + "/in.log", log + std::string(20, '\x01'));  // 20 of its 100 bytes
         return Args{"journal", "check", d + "/in.log"};
       },
       kSuccess, "end: torn last record at offset 8 (incomplete: 28 of 112 bytes written"},
      // g2o / TORO graphs (storey optimize).
      {"GraphIsADirectory",
       [](const std::string& d) {
         fs::create_directories(d + "/g");
         return Args{"optimize", d + "/g", d + "/o.g2o"};
       },
       kFailure, "/g: a directory, not a graph file"},
      {"GraphIsAFifo",
       [](const std::string& d) {
         fifo(d + "/g.g2o");
         return Args{"optimize", d + "/g.g2o", d + "/o.g2o"};
       },
       kFailure, "g.g2o: a FIFO, not a graph file"},
      {"GraphMalformedLine",
       [](const std::string& d) {
         test::writeFile(d + "/g.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0\n");
         return Args{"optimize", d + "/g.g2o", d + "/o.g2o"};
       },
       kFailure, "g.g2o:2:"},
      {"GraphNanVertex",
       [](const std::string& d) {
         test::writeFile(d + "/g.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 nan 0 0\n");
         return Args{"optimize", d + "/g.g2o", d + "/o.g2o"};
       },
       kFailure, "g.g2o:2:"},
      // CARMEN logs (storey render, storey map).
      {"CarmenIsAFifo",
       [](const std::string& d) {
         fifo(d + "/a.log");
         return Args{"render", d + "/a.log", d + "/a.png"};
       },
       kFailure, "a.log: a FIFO, not a CARMEN log"},
      {"CarmenPoseFarAway",
       [](const std::string& d) {
         test::writeFile(d + "/a.log", flaser(0, 1) + flaser(1e9, 2));
         return Args{"render", d + "/a.log", d + "/a.png"};
       },
       kFailure, "more than the 1e+08 cells a map may hold"},
      {"CarmenLineWithoutEnd",
       [](const std::string& d) {
         test::writeFile(d + "/a.log", kFlaser + std::string(5u << 20, '7'));
         return Args{"render", d + "/a.log", d + "/a.png"};
       },
       kFailure, "a.log:2: line longer than"},
      {"CarmenNanHeightOnTheCommandLine",
       [](const std::string& d) {
         test::writeFile(d + "/a.log", kFlaser);
         return Args{"map", d + "/a.log@0:nan", "--output", d + "/out"};
       },
       kFailure, "a.log@0:nan': height nan is not a number"},
      {"CarmenSkippedLinesAreReported",
       [](const std::string& d) {
         std::string log;
         for (int i = 0; i < 30; ++i) log += flaser(0.02 * i, 1 + 0.1 * i);
         log += "FLASER 5 1.0 1.1 1.2 1.3 1.4 nan 0 0 0 0 0 9 h 9\nODOM 1 2\n";  // a NaN pose, a
                                                                                 // cut line
         test::writeFile(d + "/a.log", log);
         return Args{"map", d + "/a.log@0:0", "--output", d + "/out", "--quiet"};
       },
       kSuccess, "a.log: 2 lines skipped (2 unreadable, 0 of unknown types); first unreadable: ",
       [](const std::string& d) { EXPECT_TRUE(fs::exists(d + "/out/building.yaml")); }},
      // Building files (storey simulate).
      {"BuildingDuplicateKey",
       [](const std::string& d) {
         return Args{
             "simulate",
             building(d, "{id: outer, rect: [[0.0, 0.0], [20.0, 12.0]], rect: [[0, 0], [1, 1]]}"),
             "--output", d + "/sim"};
       },
       kFailure, "duplicate key (also on line"},
      {"BuildingNanCorner",
       [](const std::string& d) {
         return Args{"simulate",
                     building(d, "{id: outer, polyline: [[0.0, 0.0], [20.0, .nan], [20.0, 12.0]]}"),
                     "--output", d + "/sim"};
       },
       kFailure, "expected a finite number, got '.nan'"},
      {"BuildingTwoKilometresWide",
       [](const std::string& d) {
         return Args{"simulate", building(d, "{id: outer, rect: [[0.0, 0.0], [2000.0, 2000.0]]}"),
                     "--output", d + "/sim"};
       },
       kSuccess, "",
       [](const std::string& d) { EXPECT_TRUE(fs::exists(d + "/sim/pictures/overlay_all.png")); }},
      {"BuildingIsADirectory",
       [](const std::string& d) {
         fs::create_directories(d + "/b.yaml");
         return Args{"simulate", d + "/b.yaml", "--output", d + "/sim"};
       },
       kFailure, "b.yaml: a directory, not a YAML file"},
      // Per-floor input lists and robots files (storey map).
      {"FloorsFileDuplicateKey",
       [](const std::string& d) {
         test::writeFile(d + "/a.log", kFlaser);
         test::writeFile(d + "/floors.yaml",
                         "floors:\n  - {path: a.log, floor: 0, floor: 1, height: 0}\n");
         return Args{"map", "--floors", d + "/floors.yaml", "--output", d + "/out"};
       },
       kFailure, "floors.yaml:2: floors[0].floor: duplicate key (also on line 2)"},
      {"RobotsFileInfiniteHeight",
       [](const std::string& d) {
         test::writeFile(d + "/robots.yaml",
                         "floor_heights: [0, .inf]\nrobots:\n  r: {start_floor: 0}\n");
         return Args{"map",      d + "/missing_bag", "--robots", d + "/robots.yaml",
                     "--output", d + "/out"};
       },
       kFailure, "robots.yaml:1: floor_heights[1]: expected a finite number"},
      // Bags (storey bag info).
      {"BagDatabaseIsAFifo",
       [](const std::string& d) {
         fifo(d + "/bag/x.db3");
         return Args{"bag", "info", d + "/bag"};
       },
       kFailure, "x.db3: a FIFO, not a bag database"},
      {"BagDatabaseIsGarbage",
       [](const std::string& d) {
         test::writeFile(d + "/bag/x.db3", std::string(4096, 'x'));
         return Args{"bag", "info", d + "/bag"};
       },
       kFailure, "x.db3"},
      {"BagMetadataDuplicateKey",
       [](const std::string& d) {
         test::writeFile(d + "/bag/metadata.yaml",
                         "rosbag2_bagfile_information:\n  version: 5\n  version: 4\n");
         return Args{"bag", "info", d + "/bag"};
       },
       kFailure,
       "metadata.yaml: line 3: rosbag2_bagfile_information.version: duplicate key (also on line "
       "2)"},
      {"BagMcapWithoutItsEnd",  // a recorder killed before it wrote the summary and footer
       [](const std::string& d) {
         std::string log;
         for (int i = 0; i < 30; ++i) log += flaser(0.02 * i, 1 + 0.1 * i);
         test::writeFile(d + "/a.log", log);
         const Outcome converted =
             run({STOREY_EXECUTABLE, "convert", d + "/a.log", d + "/bag", "--storage", "mcap"}, {},
                 d + "/convert.log");
         EXPECT_EQ(converted.status, kSuccess) << converted.output;
         // Cut where its Data End record starts: the chunks are whole, the rest is missing.
         const std::string bytes = test::readFile(d + "/bag/bag_0.mcap");
         const std::size_t data_end =
             bytes.rfind(std::string("\x0f\x04", 2) + std::string(11, '\0'));
         EXPECT_NE(data_end, std::string::npos);
         fs::resize_file(d + "/bag/bag_0.mcap", data_end);
         return Args{"map", d + "/bag", "--output", d + "/out", "--quiet"};
       },
       kSuccess, "bag_0.mcap: cut short",
       [](const std::string& d) {
         EXPECT_NE(test::readFile(d + "/out/report.html")
                       .find("<li class=\"warn\">the recording ends early"),
                   std::string::npos);
       }},
      // Component parameter files (storey component, strict options).
      {"ParametersDuplicateKey",
       [](const std::string& d) {
         test::writeFile(d + "/gs.yaml", "optimize_min_period: 0.5\noptimize_min_period: -3\n");
         return Args{"component",    "--kind",   "graph_server", "--name",     "g", "--parameters",
                     d + "/gs.yaml", "--domain", "225",          "--duration", "1"};
       },
       kFailure, "gs.yaml:2: optimize_min_period: duplicate key (also on line 1)"},
      // Ground truth (storey evaluate).
      {"TrajectoryBadCell",
       [](const std::string& d) {
         test::writeFile(d + "/result/trajectory.csv",
                         "stamp,robot,floor,x,y,theta,z\n1,r,0,nan,0,0,0\n");
         test::writeFile(d + "/truth/trajectory.csv",
                         "stamp,robot,floor,x,y,theta,z\n1,r,0,0,0,0,0\n");
         return Args{"evaluate", d + "/result", d + "/truth"};
       },
       kFailure, "trajectory.csv"},
      // Command-line numbers.
      {"ResolutionNan",
       [](const std::string& d) {
         return Args{"map", "--resolution", "nan", "--output", d + "/out"};
       },
       kUsage, "--resolution expects a finite number, got 'nan'"},
  };
}

class BadInput : public ::testing::TestWithParam<Row> {};

TEST_P(BadInput, IsRefusedClearlyWithinBounds) {
  const Row& row = GetParam();
  const std::string dir = test::makeTempDir("bad_input_" + row.name);
  const std::vector<std::string> args = row.setup(dir);
  if (HasFatalFailure()) return;
  std::vector<std::string> argv{STOREY_EXECUTABLE};
  argv.insert(argv.end(), args.begin(), args.end());
  const Outcome o = run(argv, row.env, dir + "/output.log");
  std::printf("%s: exit %d, %.2f s, peak %ld MB\n", row.name.c_str(), o.status, o.seconds,
              o.max_resident_kb / 1024);
  ASSERT_TRUE(o.exited) << "did not exit by itself (status " << o.status << "): " << o.output;
  EXPECT_EQ(o.status, row.status) << o.output;
  EXPECT_NE(o.output.find(row.expected), std::string::npos)
      << "expected '" << row.expected << "' in:\n"
      << o.output;
  EXPECT_LT(o.max_resident_kb, kMaxResidentKb);
  if (row.check && o.status == kSuccess) row.check(dir);
}

INSTANTIATE_TEST_SUITE_P(Table, BadInput, ::testing::ValuesIn(rows()),
                         [](const ::testing::TestParamInfo<Row>& info) { return info.param.name; });

}  // namespace
}  // namespace storey
