// Fleet load on one graph server (and floor matcher): N robot processes each publish the
// floor-graph updates of a mapped robot (read from a graph server journal, e.g.
// out/small2/journal.bin from `storey map`) on storey/floor_graphs (reliable, transient
// local, keep all), on the recorded schedule sped up `speed` times, each under its own
// robot name and floor-graph ids and with its own start offset (seeded). This process runs
// graph_server and floor_matcher with the shipped parameters (journal on, fdatasync per
// record) in one participant, as bringup/server.yaml does, and measures per (N, speed):
//   lost      updates published but never received by the server's process, and nodes
//             missing from the server's building at the end (both must be 0)
//   recv      publish -> delivered on the server's executor (the queue the graph server
//             applies from; its own callback journals and applies right there)
//   state     publish -> the update's nodes first appear in a published building state
//             (applied, optimised: rate-limited to one optimisation per 0.5 s)
//   CPU       server process (user+sys) as % of one core over the run; robots' total
//   peak RSS  server process (VmHWM, reset before each run)
//
//   bench_fleet [--journal J] [--robots 10,30] [--speeds 8,32] [--domain 97] [--seed 1]
//               [--no-matcher] [--no-journal-sync] [--timeout S]
#include <benchmark/benchmark.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "storey/building/journal.h"
#include "storey/common/config.h"
#include "storey/floor_matcher/floor_matcher_component.h"
#include "storey/graph_server/graph_server.h"
#include "storey/runtime/context.h"
#include "storey/runtime/graph_conversions.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/subscription.h"
#include "storey_msgs/msg/BuildingStatePubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"

namespace {

namespace fs = std::filesystem;
using UpdateMsg = storey_msgs::msg::FloorGraphUpdate;
using UpdatePub = storey::runtime::Publisher<UpdateMsg, storey_msgs::msg::FloorGraphUpdatePubSubType>;
using UpdateSub = storey::runtime::Subscription<UpdateMsg, storey_msgs::msg::FloorGraphUpdatePubSubType>;
using StateSub = storey::runtime::Subscription<storey_msgs::msg::BuildingState,
                                               storey_msgs::msg::BuildingStatePubSubType>;

constexpr int kGraphIdStride = 100;   // robot k's graph g becomes k * stride + g

std::int64_t nowNs() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);  // one clock for every process on this machine
  return static_cast<std::int64_t>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

void sleepUntilNs(std::int64_t t) {
  const std::int64_t left = t - nowNs();
  if (left > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(left));
}

std::string robotName(int k) { return "fleet" + std::to_string(k); }

struct Update {
  double offset_s = 0.0;  // on the recorded schedule, from the first update
  UpdateMsg message;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> new_nodes;  // (graph, node)
};

// Robot k's updates: the journal's floor-graph deltas, renamed (constraints are dropped:
// the matcher makes its own).
std::vector<Update> robotUpdates(const std::string& journal_path, int k) {
  const auto journal = storey::building::readJournal(journal_path);
  std::vector<Update> updates;
  double first = -1.0, last = 0.0;
  for (const auto& record : journal.records) {
    const auto* d = std::get_if<storey::building::FloorGraphDelta>(&record);
    if (!d) continue;
    const auto gid = static_cast<std::uint32_t>(k * kGraphIdStride + d->graph_id);
    Update u;
    UpdateMsg& m = u.message;
    m.robot(robotName(k));
    m.floor_graph_id(gid);
    m.floor_id(d->floor_id);
    m.floor_height(d->floor_height);
    m.sequence_number(static_cast<std::uint32_t>(updates.size()));
    for (const auto& n : d->new_nodes) {
      m.new_nodes().push_back(storey::runtime::toMessage(n, gid));
      u.new_nodes.emplace_back(gid, static_cast<std::uint32_t>(n.id));
      last = std::max(last, n.stamp);
      if (first < 0) first = n.stamp;
    }
    for (const auto& e : d->new_edges) m.new_edges().push_back(storey::runtime::toMessage(e));
    for (const auto& [id, pose] : d->poses) {
      storey_msgs::msg::NodePose p;
      p.floor_graph_id(gid);
      p.node_id(static_cast<std::uint32_t>(id));
      p.x(pose.x());
      p.y(pose.y());
      p.theta(pose.theta());
      m.optimized_poses().push_back(p);
    }
    u.offset_s = first < 0 ? 0.0 : last - first;
    updates.push_back(std::move(u));
  }
  if (updates.empty()) throw std::runtime_error(journal_path + ": no floor-graph updates in the journal");
  return updates;
}

std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }

// One robot: publish on schedule, write "sequence publish_ns" lines, then keep the writer
// (and its history) alive until told to stop, as a robot stays up.
int runRobot(const std::string& journal, int k, int domain, std::int64_t start_ns, double speed,
             const std::string& out) {
  std::signal(SIGTERM, onSignal);
  const auto updates = robotUpdates(journal, k);
  storey::runtime::ContextOptions options;
  options.domain_id = domain;
  options.participant_name = robotName(k);
  storey::runtime::Context context(options);
  UpdatePub publisher(context, "storey/floor_graphs", storey::runtime::TopicKind::kGraph);
  std::vector<std::int64_t> stamps;
  for (const auto& u : updates) {
    sleepUntilNs(start_ns + static_cast<std::int64_t>(u.offset_s / speed * 1e9));
    stamps.push_back(nowNs());
    publisher.publish(u.message);
    if (g_stop) break;
  }
  {
    std::ofstream file(out + ".tmp");
    for (std::size_t i = 0; i < stamps.size(); ++i) file << i << " " << stamps[i] << "\n";
  }
  fs::rename(out + ".tmp", out);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return 0;
}

// ---------------------------------------------------------------------------- server side

std::string withKey(const std::string& text, const std::string& key, const std::string& value) {
  std::istringstream in(text);
  std::ostringstream out;
  bool found = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key + ":", 0) == 0) {
      line = key + ": " + value;
      found = true;
    }
    out << line << "\n";
  }
  if (!found) out << key << ": " << value << "\n";
  return out.str();
}

std::string readText(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

double cpuSeconds(const rusage& r) {
  return r.ru_utime.tv_sec + r.ru_stime.tv_sec + 1e-6 * (r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

long statusKb(const char* field) {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(field, 0) == 0) return std::strtol(line.c_str() + std::strlen(field) + 1, nullptr, 10);
  return -1;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  return v[std::min(i, v.size() - 1)];
}

struct RunResult {
  int robots = 0;
  double speed = 0;
  double offered_per_s = 0;
  std::uint64_t expected = 0, received = 0, accepted = 0, rejected = 0;
  std::uint64_t nodes_expected = 0, nodes_held = 0;
  std::vector<double> recv_ms, state_ms;
  double server_cpu_percent = 0, robots_cpu_s = 0, wall_s = 0;
  long peak_rss_mb = 0;
  std::size_t matchings = 0, constraints = 0;
  bool complete = false;
};

struct Options {
  std::string self;
  std::string journal = std::string(STOREY_SOURCE_DIR) + "/out/small2/journal.bin";
  std::vector<int> robots = {10, 30};
  std::vector<double> speeds = {8, 32};
  int domain = 97;
  unsigned seed = 1;
  bool matcher = true;
  bool journal_sync = true;
  double timeout = 120;
};

RunResult runFleet(const Options& o, int n, double speed, const std::string& dir) {
  namespace rt = storey::runtime;
  RunResult r;
  r.robots = n;
  r.speed = speed;
  const auto updates = robotUpdates(o.journal, 0);
  const double span = updates.back().offset_s / speed;
  r.expected = static_cast<std::uint64_t>(n) * updates.size();
  for (const auto& u : updates) r.nodes_expected += u.new_nodes.size();
  r.nodes_expected *= static_cast<std::uint64_t>(n);
  r.offered_per_s = static_cast<double>(r.expected) / std::max(span, 1e-3);

  // Received (robot, sequence) -> ns, and the first building state holding each node.
  std::mutex mutex;
  std::map<std::pair<int, std::uint32_t>, std::int64_t> received;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::int64_t> node_seen;
  const std::string config = std::string(STOREY_SOURCE_DIR) + "/config/";
  const std::string journal_out = dir + "/journal_" + std::to_string(n) + "_" + std::to_string(int(speed)) + ".bin";
  fs::remove(journal_out);

  std::ofstream("/proc/self/clear_refs") << "5";  // resets VmHWM
  rusage self0{}, children0{};
  getrusage(RUSAGE_SELF, &self0);
  getrusage(RUSAGE_CHILDREN, &children0);
  const auto wall0 = std::chrono::steady_clock::now();
  std::vector<pid_t> pids;
  {
    rt::ContextOptions options;
    options.domain_id = o.domain;
    options.participant_name = "fleet_server";
    rt::Context context(options);
    const auto gs_params = storey::common::ConfigNode::loadString(
        withKey(withKey(readText(config + "graph_server.yaml"), "journal", journal_out), "journal_sync",
                o.journal_sync ? "true" : "false"), config + "graph_server.yaml");
    storey::graph_server::GraphServer server(context, gs_params, "graph_server");
    const auto fm_params = storey::common::ConfigNode::loadFile(config + "floor_matcher.yaml");
    std::unique_ptr<storey::floor_matcher::FloorMatcherComponent> matcher;
    if (o.matcher)
      matcher = std::make_unique<storey::floor_matcher::FloorMatcherComponent>(context, fm_params, "floor_matcher");
    UpdateSub updates_sub(context, "storey/floor_graphs", rt::TopicKind::kGraph, [&](const UpdateMsg& m) {
      const std::int64_t t = nowNs();
      const int k = std::atoi(m.robot().c_str() + 5);
      std::lock_guard<std::mutex> lock(mutex);
      received.emplace(std::make_pair(k, m.sequence_number()), t);
    });
    StateSub state_sub(context, "storey/building_state", rt::TopicKind::kGraph,
                       [&](const storey_msgs::msg::BuildingState& s) {
                         const std::int64_t t = nowNs();
                         std::lock_guard<std::mutex> lock(mutex);
                         for (const auto& p : s.node_poses())
                           node_seen.emplace(std::make_pair(p.floor_graph_id(), p.node_id()), t);
                       });
    if (matcher) matcher->configure();
    server.configure();
    if (matcher) matcher->activate();
    server.activate();

    // Robots start together after discovery, each offset by up to 1 s.
    std::mt19937 rng(o.seed);
    std::uniform_real_distribution<double> jitter(0.0, 1.0);
    const std::int64_t start = nowNs() + static_cast<std::int64_t>((2.0 + 0.05 * n) * 1e9);
    for (int k = 0; k < n; ++k) {
      const std::int64_t robot_start = start + static_cast<std::int64_t>(jitter(rng) * 1e9);
      const std::string out = dir + "/robot_" + std::to_string(k) + ".txt";
      fs::remove(out);
      const pid_t pid = fork();
      if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGTERM);  // a robot outlives no crashed bench
        const std::vector<std::string> args = {o.self,       "--robot",  std::to_string(k),
                                               "--journal",  o.journal,  "--domain",
                                               std::to_string(o.domain), "--start", std::to_string(robot_start),
                                               "--speed",    std::to_string(speed), "--out", out};
        std::vector<char*> argv;
        for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        execv(argv[0], argv.data());
        _exit(127);
      }
      pids.push_back(pid);
    }
    // Until everything arrived and is in a building state, or the timeout.
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration<double>(2.0 + 0.05 * n + 1.0 + span + o.timeout);
    while (std::chrono::steady_clock::now() < deadline) {
      std::size_t got = 0, seen = 0;
      {
        std::lock_guard<std::mutex> lock(mutex);
        got = received.size();
        seen = node_seen.size();
      }
      if (got >= r.expected && seen >= r.nodes_expected) {
        r.complete = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    rusage self1{};
    getrusage(RUSAGE_SELF, &self1);
    r.server_cpu_percent = 100.0 * (cpuSeconds(self1) - cpuSeconds(self0)) / r.wall_s;
    r.peak_rss_mb = statusKb("VmHWM:") / 1024;
    const auto stats = server.stats();
    r.accepted = stats.updates_accepted;
    r.rejected = stats.rejected;
    const auto snapshot = server.snapshot();
    for (const auto& [id, g] : snapshot.first.floorGraphs()) r.nodes_held += g.nodes.size();
    for (pid_t pid : pids) kill(pid, SIGTERM);
    for (pid_t pid : pids) waitpid(pid, nullptr, 0);
    rusage children1{};
    getrusage(RUSAGE_CHILDREN, &children1);
    r.robots_cpu_s = cpuSeconds(children1) - cpuSeconds(children0);
    if (matcher) {
      const auto ms = matcher->stats();
      r.matchings = ms.matchings;
      r.constraints = ms.constraints_published;
      matcher->deactivate();  // waits for a matching in progress
    }
    server.deactivate();
  }
  r.received = received.size();
  for (int k = 0; k < n; ++k) {
    std::ifstream in(dir + "/robot_" + std::to_string(k) + ".txt");
    const auto robot_updates = robotUpdates(o.journal, k);
    std::uint32_t seq = 0;
    for (std::int64_t t_pub = 0; in >> seq >> t_pub;) {
      auto it = received.find({k, seq});
      if (it != received.end()) r.recv_ms.push_back(1e-6 * static_cast<double>(it->second - t_pub));
      const auto& nodes = robot_updates.at(seq).new_nodes;
      if (nodes.empty()) continue;
      std::int64_t last_seen = 0;
      bool all = true;
      for (const auto& node : nodes) {
        auto s = node_seen.find(node);
        if (s == node_seen.end()) {
          all = false;
          break;
        }
        last_seen = std::max(last_seen, s->second);
      }
      if (all) r.state_ms.push_back(1e-6 * static_cast<double>(last_seen - t_pub));
    }
  }
  return r;
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) items.push_back(item);
  return items;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  o.self = fs::canonical("/proc/self/exe").string();
  int robot = -1;
  std::int64_t start = 0;
  double speed = 1;
  std::string out;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_fleet: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--journal") o.journal = value();
    else if (a == "--robots") {
      o.robots.clear();
      for (const auto& s : splitList(value())) o.robots.push_back(std::stoi(s));
    } else if (a == "--speeds") {
      o.speeds.clear();
      for (const auto& s : splitList(value())) o.speeds.push_back(std::stod(s));
    } else if (a == "--domain") o.domain = std::stoi(value());
    else if (a == "--seed") o.seed = static_cast<unsigned>(std::stoul(value()));
    else if (a == "--no-matcher") o.matcher = false;
    else if (a == "--no-journal-sync") o.journal_sync = false;
    else if (a == "--timeout") o.timeout = std::stod(value());
    else if (a == "--robot") robot = std::stoi(value());
    else if (a == "--start") start = std::stoll(value());
    else if (a == "--speed") speed = std::stod(value());
    else if (a == "--out") out = value();
    else {
      std::fprintf(stderr,
                   "usage: bench_fleet [--journal J] [--robots 10,30] [--speeds 8,32] [--domain D] "
                   "[--seed S] [--no-matcher] [--no-journal-sync] [--timeout S]\n");
      return a == "--help" ? 0 : 2;
    }
  }
  try {
    if (robot >= 0) return runRobot(o.journal, robot, o.domain, start, speed, out);
    if (!fs::exists(o.journal)) {
      std::fprintf(stderr, "bench_fleet: %s does not exist: run `storey map` first, or pass --journal\n",
                   o.journal.c_str());
      return 1;
    }
    const std::string dir = (fs::temp_directory_path() / ("bench_fleet_" + std::to_string(getpid()))).string();
    fs::create_directories(dir);
    const auto one = robotUpdates(o.journal, 0);
    std::size_t nodes = 0;
    for (const auto& u : one) nodes += u.new_nodes.size();
    std::printf("fleet load: each robot publishes %zu floor-graph updates (%zu nodes) over %.1f s of "
                "recording (%s); domain %d; matcher %s; journal fdatasync %s\n\n",
                one.size(), nodes, one.back().offset_s, o.journal.c_str(), o.domain, o.matcher ? "on" : "off",
                o.journal_sync ? "on" : "off");
    std::printf("%6s %6s %9s %9s %6s %7s | %8s %8s %8s %8s | %8s %8s %8s | %7s %8s %7s | %5s %5s\n", "robots",
                "speed", "offered/s", "received", "lost", "missing", "recv p50", "p90", "p99", "max",
                "state p50", "p90", "p99", "srv CPU", "robots s", "RSS MB", "match", "cons");
    for (int n : o.robots) {
      for (double s : o.speeds) {
        const RunResult r = runFleet(o, n, s, dir);
        const auto ms = [](const std::vector<double>& v, double q) { return percentile(v, q); };
        std::printf("%6d %6g %9.1f %9llu %6llu %7llu | %8.1f %8.1f %8.1f %8.1f | %8.0f %8.0f %8.0f | %6.0f%% "
                    "%8.1f %7ld | %5zu %5zu%s\n",
                    r.robots, r.speed, r.offered_per_s, static_cast<unsigned long long>(r.received),
                    static_cast<unsigned long long>(r.expected - std::min(r.expected, r.received)),
                    static_cast<unsigned long long>(r.nodes_expected - std::min(r.nodes_expected, r.nodes_held)),
                    ms(r.recv_ms, 0.5), ms(r.recv_ms, 0.9), ms(r.recv_ms, 0.99), ms(r.recv_ms, 1.0),
                    ms(r.state_ms, 0.5), ms(r.state_ms, 0.9), ms(r.state_ms, 0.99), r.server_cpu_percent,
                    r.robots_cpu_s, r.peak_rss_mb, r.matchings, r.constraints,
                    r.complete ? "" : "  (timed out)");
        std::fflush(stdout);
      }
    }
    std::error_code ec;
    fs::remove_all(dir, ec);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_fleet: %s\n", e.what());
    return 1;
  }
  return 0;
}
