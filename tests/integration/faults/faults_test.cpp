// Faults of a deployment fed by `storey replay` (issues #9 and #10): a component killed
// with SIGKILL in the middle of the replay and restarted leaves the building an
// undisturbed run gives; and the split deployment gives the single process's building.
//
// Each test simulates the bundled building (small2, cut to its first two floor visits so
// a run fits in about 25 s), runs the components as storey processes on its own DDS
// domain, with sensor topics reliable (reliable_sensors_qos.xml: nothing is lost however
// loaded the machine), replays the bag at 10x, waits until the matchers have matched the
// final floor graphs (after 2 s without updates: match_after_idle) and the journals are
// still, stops everything, and rebuilds the buildings from the graph servers' journals as
// `storey export` does. The undisturbed reference is a witness in the same run, on topics
// of its own, downstream of the component under test (two separate runs would differ by
// thread timing alone).
//
// DDS domains: 240-249 are not valid with Fast DDS' default port mapping (at most 232),
// so these tests use 140-145.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/building/journal.h"
#include "test_support.h"

namespace storey {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kReplayRate = 10.0;
// A killed process is restarted after this, 2 s past the 3 s participant lease of
// reliable_sensors_qos.xml (its participant profile is named storey_participant, the
// name the runtime applies), so the others have dropped the dead participant.
constexpr double kRestartAfter = 5.0;  // s
constexpr double kSimulatedSeconds = 135.0;  // F0, the elevator to F1, F1's rooms
// Tolerances for "the same building" (see docs/reliability.md for what was measured).
constexpr double kPositionTolerance = 0.05;  // m, node poses and floor transforms
constexpr double kAngleTolerance = 0.01;     // rad
constexpr double kHeightTolerance = 0.01;    // m

const std::string kStorey = STOREY_EXECUTABLE;

void sleepFor(double seconds) {
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
}

// Starts argv with stdout and stderr appended to `log`.
pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    FILE* out = std::fopen(log.c_str(), "a");
    if (out) {
      dup2(fileno(out), 1);
      dup2(fileno(out), 2);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// Waits for `pid`; kills it after `timeout_s`. Returns the wait status.
int waitFor(pid_t pid, double timeout_s) {
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (Clock::now() > end) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    sleepFor(0.02);
  }
  return status;
}

std::size_t countOf(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::uintmax_t fileSize(const std::string& path) {
  std::error_code error;
  const auto size = fs::file_size(path, error);
  return error ? 0 : size;
}

// The recording every test replays: small2 for its first kSimulatedSeconds.
std::string simulate(const std::string& dir) {
  const std::string out = dir + "/sim";
  const std::string log = dir + "/simulate.log";
  const pid_t pid = spawn({kStorey, "simulate", test::sourceDir() + "/config/buildings/small2.yaml",
                           "--output", out, "--no-pictures", "--max-duration",
                           std::to_string(kSimulatedSeconds)},
                          log);
  const int status = waitFor(pid, 60);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << test::readFile(log);
  return out + "/bag";
}

struct Building {
  building::BuildingGraph graph;
  building::BuildingSolution solution;
};

Building rebuild(const std::string& journal) {
  Building b;
  b.graph = building::rebuildFromJournal(journal).graph;  // an rvalue: moved, not copied
  b.solution = b.graph.optimize();
  return b;
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 2 * M_PI)); }

struct Comparison {
  std::string text;  // what differs, for the test log
  double max_position = 0.0, max_angle = 0.0;     // over nodes matched by stamp
  double max_transform = 0.0, max_transform_angle = 0.0, max_height = 0.0;
  int node_count_difference = 0;  // summed over floor graphs
  int unmatched_nodes = 0;
  bool same_graphs = true;  // same graph ids, floors, alignment
  int constraints_a = 0, constraints_b = 0;
};

// Compares B with reference A: floor graphs (ids, floors, heights, aligned, transforms),
// node counts, and node poses in the building frame, nodes matched by their scan stamps.
Comparison compare(const Building& a, const Building& b) {
  Comparison c;
  std::ostringstream text;
  c.constraints_a = static_cast<int>(a.graph.constraints().size());
  c.constraints_b = static_cast<int>(b.graph.constraints().size());
  text << "constraints " << c.constraints_a << " / " << c.constraints_b << "\n";
  if (a.graph.floorGraphs().size() != b.graph.floorGraphs().size()) c.same_graphs = false;
  for (const auto& [id, ga] : a.graph.floorGraphs()) {
    auto it = b.graph.floorGraphs().find(id);
    if (it == b.graph.floorGraphs().end()) {
      c.same_graphs = false;
      text << "graph " << id << " missing\n";
      continue;
    }
    const auto& gb = it->second;
    const auto* pa = a.solution.placement(id);
    const auto* pb = b.solution.placement(id);
    if (ga.floor_id != gb.floor_id || !pa || !pb || pa->aligned != pb->aligned) c.same_graphs = false;
    if (pa && pb) {
      c.max_transform = std::max(c.max_transform, (pa->transform.translation() - pb->transform.translation()).norm());
      c.max_transform_angle = std::max(c.max_transform_angle, angleDiff(pa->transform.theta(), pb->transform.theta()));
      c.max_height = std::max(c.max_height, std::abs(pa->height - pb->height));
      text << "graph " << id << " floor " << ga.floor_id << ": nodes " << ga.nodes.size() << " / "
           << gb.nodes.size() << ", aligned " << pa->aligned << " / " << pb->aligned << ", transform ("
           << pa->transform.x() << ", " << pa->transform.y() << ", " << pa->transform.theta() << ") / ("
           << pb->transform.x() << ", " << pb->transform.y() << ", " << pb->transform.theta() << ")\n";
    }
    c.node_count_difference += std::abs(static_cast<int>(ga.nodes.size()) - static_cast<int>(gb.nodes.size()));
    std::map<double, int> by_stamp;
    for (const auto& n : gb.nodes) by_stamp[n.stamp] = n.id;
    for (const auto& n : ga.nodes) {
      auto m = by_stamp.find(n.stamp);
      if (m == by_stamp.end()) {
        ++c.unmatched_nodes;
        continue;
      }
      auto qa = a.solution.poses.find({id, n.id});
      auto qb = b.solution.poses.find({id, m->second});
      if (qa == a.solution.poses.end() || qb == b.solution.poses.end()) continue;
      c.max_position = std::max(c.max_position, (qa->second.translation() - qb->second.translation()).norm());
      c.max_angle = std::max(c.max_angle, angleDiff(qa->second.theta(), qb->second.theta()));
    }
  }
  text << "max node difference " << c.max_position << " m, " << c.max_angle << " rad; transforms "
       << c.max_transform << " m, " << c.max_transform_angle << " rad; heights " << c.max_height
       << " m; node counts differ by " << c.node_count_difference << ", unmatched " << c.unmatched_nodes;
  c.text = text.str();
  return c;
}

void expectSameBuilding(const Comparison& c) {
  std::printf("%s\n", c.text.c_str());
  EXPECT_TRUE(c.same_graphs) << c.text;
  EXPECT_EQ(c.constraints_a, c.constraints_b) << c.text;
  // Not a property of the fault: it says whether constraints were part of the comparison.
  if (c.constraints_a == 0) std::printf("note: no inter-floor constraint in this run (floor graphs compared alone)\n");
  EXPECT_EQ(c.node_count_difference, 0) << c.text;
  EXPECT_EQ(c.unmatched_nodes, 0) << c.text;
  EXPECT_LE(c.max_position, kPositionTolerance) << c.text;
  EXPECT_LE(c.max_angle, kAngleTolerance) << c.text;
  EXPECT_LE(c.max_transform, kPositionTolerance) << c.text;
  EXPECT_LE(c.max_transform_angle, kAngleTolerance) << c.text;
  EXPECT_LE(c.max_height, kHeightTolerance) << c.text;
}

// Replaces every `from` in `text`; throws when there is none (a shipped file changed).
std::string replaceAll(std::string text, const std::string& from, const std::string& to) {
  if (text.find(from) == std::string::npos)
    throw std::runtime_error("replaceAll: '" + from + "' not in the text");
  for (auto at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

// One run: the pipeline under test (detector, mapper, matcher, graph server, in processes
// as `layout` says) and, beside it, a witness pipeline in one process of its own, reading
// the same sensor topics and writing to topics of its own (witness/...). Two separate runs
// would differ by thread timing alone; the witness sees the very same input.
class Deployment {
 public:
  enum class Layout {
    kOnePerComponent,  // processes detector, mapper, matcher, server
    kSplit,            // as bringup/split.yaml: robot1 (detector + mapper), server (matcher + graph server)
  };

  // What the witness runs: the whole pipeline on its own topics, or only the part
  // downstream of the component under test (then the two share their input exactly).
  enum class Witness { kPipeline, kMatcherAndServer, kServer };

  Deployment(const std::string& dir, int domain, Layout layout, Witness witness = Witness::kPipeline)
      : dir_(dir), domain_(domain) {
    fs::create_directories(dir_);
    const std::string config = test::sourceDir() + "/config/";
    write("graph_server.yaml", "journal: " + journal() + "\n");
    // Both mappers wait for a silent detector up to 300 s of scans, not 30: at 10x that is
    // 30 s, not 3 s, of wall time, and a detector restarted under load took longer than 3 s
    // to catch up on the sensor history (the mapper then mapped on without its floor events).
    const std::string mapper_parameters =
        replaceAll(test::readFile(config + "floor_mapper.yaml"), "max_floor_detector_lag: 30.0",
                   "max_floor_detector_lag: 300.0");
    // The mapper under test logs its input, so that a restart resumes its graphs.
    write("floor_mapper.yaml",
          replaceAll(mapper_parameters, "input_log: \"\"", "input_log: " + mapperInputLog()));
    // The witness: the shipped parameters on witness topics.
    write("witness_floor_detector.yaml",
          replaceAll(test::readFile(config + "floor_detector.yaml"), "events_topic: floor_events",
                     "events_topic: witness_floor_events"));
    write("witness_floor_mapper.yaml",
          replaceAll(replaceAll(mapper_parameters, "events_topic: floor_events", "events_topic: witness_floor_events"),
                     "floor_graph_topic: storey/floor_graphs", "floor_graph_topic: witness/floor_graphs"));
    const std::string graphs = witness == Witness::kPipeline ? "witness/floor_graphs" : "storey/floor_graphs";
    const std::string constraints =
        witness == Witness::kServer ? "storey/inter_floor_constraints" : "witness/inter_floor_constraints";
    // Matching after 5 s without updates (2 s by default): on this loaded 2-core machine the
    // mapper stalls for 2 s now and then, and a matching in a stall depends on its timing.
    // Matching only after the replay (not while graphs grow): a matching of growing graphs
    // depends on which state it catches, and its constraints stay.
    const std::string matcher_parameters =
        replaceAll(replaceAll(test::readFile(config + "floor_matcher.yaml"), "match_after_idle: 2.0",
                              "match_after_idle: 5.0"),
                   "match_while_growing: true", "match_while_growing: false");
    write("floor_matcher.yaml", matcher_parameters);
    // The witness matcher reads its own server's state: a matcher adopts the constraints
    // the server whose state it reads holds (what a restarted matcher's predecessor published).
    write("witness_floor_matcher.yaml",
          replaceAll(replaceAll(replaceAll(matcher_parameters, "floor_graph_topic: storey/floor_graphs",
                                           "floor_graph_topic: " + graphs),
                                "constraint_topic: storey/inter_floor_constraints",
                                "constraint_topic: " + constraints),
                     "building_state_topic: storey/building_state",
                     "building_state_topic: witness/building_state"));
    write("witness_graph_server.yaml", "journal: " + witnessJournal() + "\nfloor_graph_topic: " + graphs +
                                           "\nconstraint_topic: " + constraints +
                                           "\nbuilding_state_topic: witness/building_state\n"
                                           "floor_map_topic_prefix: witness/floor_maps\n");
    const std::string header = "    domain_id: " + std::to_string(domain) + "\n    components:\n";
    const std::string detector = "      - {kind: floor_detector, name: robot1_floor_detector, parameters: " + config +
                                 "floor_detector.yaml}\n";
    const std::string mapper = "      - {kind: floor_mapper, name: robot1_floor_mapper, parameters: floor_mapper.yaml}\n";
    const std::string matcher = "      - {kind: floor_matcher, name: floor_matcher, parameters: floor_matcher.yaml}\n";
    const std::string server = "      - {kind: graph_server, name: graph_server, parameters: graph_server.yaml}\n";
    std::string text = "processes:\n";
    if (layout == Layout::kOnePerComponent) {
      processes_ = {"detector", "mapper", "matcher", "server"};
      text += "  - name: detector\n" + header + detector + "  - name: mapper\n" + header + mapper +
              "  - name: matcher\n" + header + matcher + "  - name: server\n" + header + server;
    } else {
      processes_ = {"robot1", "server"};
      text += "  - name: robot1\n" + header + detector + mapper + "  - name: server\n" + header + matcher + server;
    }
    processes_.push_back("witness");
    text += "  - name: witness\n" + header;
    if (witness == Witness::kPipeline)
      text += "      - {kind: floor_detector, name: witness_detector, parameters: witness_floor_detector.yaml}\n"
              "      - {kind: floor_mapper, name: witness_mapper, parameters: witness_floor_mapper.yaml}\n";
    if (witness != Witness::kServer)
      text += "      - {kind: floor_matcher, name: witness_matcher, parameters: witness_floor_matcher.yaml}\n";
    text += "      - {kind: graph_server, name: witness_server, parameters: witness_graph_server.yaml}\n";
    witness_matches_ = witness != Witness::kServer;
    subscribers_ = witness == Witness::kPipeline ? 4 : 2;
    write("bringup.yaml", text);
  }
  ~Deployment() { stop(); }

  std::string journal() const { return dir_ + "/journal.bin"; }
  std::string mapperInputLog() const { return dir_ + "/mapper_input.log"; }
  std::string witnessJournal() const { return dir_ + "/witness_journal.bin"; }
  std::string bringup() const { return dir_ + "/bringup.yaml"; }

  // `storey launch` (one child per process).
  void launch() { pids_["launch"] = spawn({kStorey, "launch", bringup()}, log("launch")); }
  // Each process started here, so one can be killed and restarted alone.
  void startAll() {
    for (const auto& p : processes_) start(p);
  }
  void start(const std::string& process) {
    pids_[process] = spawn({kStorey, "component", "--bringup", bringup(), "--process", process}, log(process));
  }
  void killHard(const std::string& process) {
    ASSERT_TRUE(pids_.count(process));
    kill(pids_[process], SIGKILL);
    const int status = waitFor(pids_[process], 10);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    pids_.erase(process);
  }

  // Replays the bag in the background (returns at once), once both detectors and both
  // mappers subscribe.
  void startReplay(const std::string& bag, double rate = kReplayRate) {
    // Components drop input until active: wait until every process says it runs.
    const auto end = Clock::now() + std::chrono::seconds(30);
    while (running() < processes_.size() && Clock::now() < end) sleepFor(0.05);
    ASSERT_EQ(running(), processes_.size()) << logs();
    replay_ = spawn(
        {kStorey, "replay", bag, "--rate", std::to_string(rate), "--domain",
         std::to_string(domain_), "--subscribers", std::to_string(subscribers_), "--wait", "0.5",
         // Every reliable subscriber, a restarted one catching up on the
         // history included, gets every sample before the replay (the only
         // writer) exits. A restarted detector caught up 2.6 s after the last
         // message here, 6.6 s beside a busy loop; the replay leaves as soon
         // as all have acknowledged, so the bound costs nothing when they do.
         "--ack-wait", "30", "--quiet"},
        log("replay"));
    replay_start_ = Clock::now();
  }
  double sinceReplayStart() const { return std::chrono::duration<double>(Clock::now() - replay_start_).count(); }
  // Waits for the replay to end, then for both matchers to match after it published its
  // last message and both journals to stay still for 3 s; then stops everything.
  void finish() {
    // Matchings count from the end of publishing: the replay then waits for every
    // subscriber's acknowledgments (seconds for a restarted one catching up on the
    // history), and the matchers' idle rule may fire while it waits.
    const auto published_by = Clock::now() + std::chrono::seconds(120);
    while (!replayPublishedAll() && Clock::now() < published_by) sleepFor(0.05);
    const std::size_t main_before = matchings("] floor_matcher: matched");
    const std::size_t witness_before = matchings("witness_matcher: matched");
    const int status = waitFor(replay_, 120);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << test::readFile(log("replay"));
    const auto end = Clock::now() + std::chrono::seconds(60);
    auto witnessDone = [&] { return !witness_matches_ || matchings("witness_matcher: matched") > witness_before; };
    while ((matchings("] floor_matcher: matched") <= main_before || !witnessDone()) && Clock::now() < end)
      sleepFor(0.1);
    EXPECT_GT(matchings("] floor_matcher: matched"), main_before) << "no matching after the replay\n" << logs();
    EXPECT_TRUE(witnessDone()) << "no witness matching after the replay";
    std::uintmax_t size = fileSize(journal()) + fileSize(witnessJournal());
    auto still_since = Clock::now();
    // 3 s: under a load average of 14 a graph server once still lagged after 1 s.
    while (Clock::now() - still_since < std::chrono::seconds(3) && Clock::now() < end) {
      sleepFor(0.1);
      const auto now = fileSize(journal()) + fileSize(witnessJournal());
      if (now != size) {
        size = now;
        still_since = Clock::now();
      }
    }
    stop();
  }
  // SIGTERM to everything still running; every process must stop cleanly.
  void stop() {
    for (auto& [name, pid] : pids_) kill(pid, SIGTERM);
    for (auto& [name, pid] : pids_) {
      const int status = waitFor(pid, 20);
      EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
          << "process " << name << " status " << status << "\n"
          << test::readFile(log(name));
    }
    pids_.clear();
  }
  std::string log(const std::string& name) const { return dir_ + "/" + name + ".log"; }
  // Processes that logged "running N component(s)", restarted ones included.
  std::size_t running() const {
    std::size_t n = countOf(test::readFile(log("launch")), "] running ");
    for (const auto& p : processes_) n += countOf(test::readFile(log(p)), "] running ");
    return n;
  }
  bool replayPublishedAll() const {
    return test::readFile(log("replay")).find("messages published") != std::string::npos;
  }
  std::size_t matchings(const std::string& line) const {
    std::size_t n = 0;
    for (const auto& name : {"launch", "matcher", "server", "witness"})
      n += countOf(test::readFile(log(name)), line);
    return n;
  }
  // Every process's log without its DDS discovery lines first (a CI log keeps the head
  // of a long failure message), then the whole logs.
  std::string logs() const {
    const auto names = {"replay", "launch", "detector", "mapper", "matcher", "server", "robot1", "witness"};
    std::string all;
    for (const auto& name : names) {
      if (!fs::exists(log(name))) continue;
      all += std::string("---- ") + name + " (without dds: lines)\n";
      std::istringstream in(test::readFile(log(name)));
      for (std::string line; std::getline(in, line);)
        if (line.find("] dds: ") == std::string::npos) all += line + "\n";
    }
    for (const auto& name : names)
      if (fs::exists(log(name)))
        all += std::string("---- ") + name + "\n" + test::readFile(log(name));
    return all;
  }

 private:
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_ + "/" + name) << text; }
  std::string dir_;
  int domain_;
  std::vector<std::string> processes_;
  std::map<std::string, pid_t> pids_;
  pid_t replay_ = -1;
  Clock::time_point replay_start_;
  bool witness_matches_ = true;
  int subscribers_ = 4;
};

class FaultsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::makeTempDir("faults");
    // Every storey process started here inherits it: sensor topics reliable too.
    setenv("STOREY_QOS_PROFILES", (test::sourceDir() + "/tests/integration/faults/reliable_sensors_qos.xml").c_str(),
           1);
    // Debug lines include each process's DDS discovery and reader matches: when a
    // restarted process takes no sample, its log shows whether it matched anyone.
    setenv("STOREY_LOG_LEVEL", "debug", 1);
    bag_ = simulate(dir_);
  }
  void TearDown() override {
    if (HasFailure()) std::printf("logs in %s\n", dir_.c_str());
    // Killed processes leave shared-memory segments; this removes only unused ones.
    if (std::system("fastdds shm clean >/dev/null 2>&1") != 0) std::printf("note: fastdds shm clean failed\n");
  }
  // One component per process; `process` killed (SIGKILL) `kill_at` seconds into the
  // replay and restarted kRestartAfter seconds later. Returns (under test, witness).
  std::pair<Building, Building> withRestart(int domain, const std::string& process, double kill_at,
                                            Deployment::Witness witness) {
    Deployment d(dir_ + "/" + process, domain, Deployment::Layout::kOnePerComponent, witness);
    d.startAll();
    d.startReplay(bag_);
    while (d.sinceReplayStart() < kill_at) sleepFor(0.05);
    // A mapper killed before it logged any input has nothing to resume from (under load
    // the replay can start publishing seconds after it started): wait for its first input.
    // (The log's 8-byte magic is written when the mapper starts.)
    while (process == "mapper" && fileSize(d.mapperInputLog()) <= 8 && d.sinceReplayStart() < kill_at + 20)
      sleepFor(0.05);
    d.killHard(process);
    sleepFor(kRestartAfter);
    d.start(process);
    d.finish();
    // The server rebuilt what it had from its journal, the mapper from its input log.
    if (process == "server" || process == "mapper") {
      EXPECT_NE(test::readFile(d.log(process)).find(": resumed "), std::string::npos)
          << test::readFile(d.log(process));
    }
    return {rebuild(d.journal()), rebuild(d.witnessJournal())};
  }
  std::string dir_, bag_;
};

// Issue #9: bringup split as a robot and a server process (bringup/split.yaml, under
// `storey launch`) gives the building of the same components in one process. It holds
// since the mapper orders scans and floor events by their stamps (InputSequencer), not by
// their arrival.
TEST_F(FaultsTest, SplitDeploymentEqualsSingleProcess) {
  Deployment d(dir_ + "/split", 140, Deployment::Layout::kSplit);
  d.launch();
  d.startReplay(bag_);
  d.finish();
  expectSameBuilding(compare(rebuild(d.witnessJournal()), rebuild(d.journal())));
}

TEST_F(FaultsTest, GraphServerKilledAndRestartedGivesTheSameBuilding) {
  const auto [b, witness] = withRestart(141, "server", 6.0, Deployment::Witness::kServer);
  expectSameBuilding(compare(witness, b));
}

// The graph server killed and restarted five times during one replay (slowed to 3x so
// that five restarts fit in it). Each restart resumes from the journal and gets the
// topics' whole history again, which must not be journalled again: the journal holds the
// very records of the witness server's, which runs undisturbed on the same topics, each
// once, and gives the same building.
TEST_F(FaultsTest, GraphServerKilledFiveTimesJournalsEveryRecordOnce) {
  Deployment d(dir_ + "/server5", 145, Deployment::Layout::kOnePerComponent,
               Deployment::Witness::kServer);
  d.startAll();
  d.startReplay(bag_, 3.0);
  for (int kill = 1; kill <= 5; ++kill) {
    // Running (and, after a restart, resumed), then 1.5 s of updates.
    const auto end = Clock::now() + std::chrono::seconds(30);
    while (countOf(test::readFile(d.log("server")), "] running ") <
               static_cast<std::size_t>(kill) &&
           Clock::now() < end)
      sleepFor(0.05);
    sleepFor(1.5);
    ASSERT_FALSE(d.replayPublishedAll()) << "the replay ended before kill " << kill;
    d.killHard("server");
    sleepFor(kRestartAfter);
    d.start("server");
  }
  d.finish();
  EXPECT_EQ(countOf(test::readFile(d.log("server")), ": resumed "), 5u)
      << test::readFile(d.log("server"));
  std::map<std::vector<std::uint8_t>, int> records, witness_records;
  for (const auto& r : building::readJournal(d.journal()).records)
    ++records[building::encodeRecord(r)];
  for (const auto& r : building::readJournal(d.witnessJournal()).records)
    ++witness_records[building::encodeRecord(r)];
  for (const auto& [bytes, count] : records)
    EXPECT_EQ(count, 1) << "a record journalled " << count << " times";
  EXPECT_TRUE(records == witness_records)
      << records.size() << " distinct records, the witness " << witness_records.size();
  EXPECT_EQ(building::checkJournal(d.journal()).repeated_updates, 0u);
  expectSameBuilding(compare(rebuild(d.witnessJournal()), rebuild(d.journal())));
}

TEST_F(FaultsTest, MatcherKilledAndRestartedGivesTheSameBuilding) {
  const auto [b, witness] = withRestart(142, "matcher", 6.0, Deployment::Witness::kMatcherAndServer);
  expectSameBuilding(compare(witness, b));
}

// The restarted detector gets the sensor history again (transient local here) and sends
// the same events; the mapper skips those it took before.
TEST_F(FaultsTest, DetectorKilledAndRestartedGivesTheSameBuilding) {
  const auto [b, witness] = withRestart(143, "detector", 2.0, Deployment::Witness::kPipeline);
  expectSameBuilding(compare(witness, b));
}

// The restarted mapper replays its input log (same graphs, same updates re-sent) and
// resumes after the last logged scan with what the sensor topics' history gives it.
// Killed 3 s into the 13.5 s replay, back 5 s later: the sensor history it needs lives in
// the replay process, which exits when it has published everything. Killed at 6 s, the
// restarted mapper had 2.5 s to start and take that history; at a load average of 5 it
// did not (floor 1 mapped 11-27 of 66 nodes, 2 runs of 3 on a loaded machine).
TEST_F(FaultsTest, MapperKilledAndRestartedGivesTheSameBuilding) {
  const auto [b, witness] = withRestart(144, "mapper", 3.0, Deployment::Witness::kPipeline);
  expectSameBuilding(compare(witness, b));
}

}  // namespace
}  // namespace storey
