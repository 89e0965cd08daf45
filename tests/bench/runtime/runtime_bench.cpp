// End-to-end latency and throughput of a 1080-beam LaserScan through storey's runtime
// (Publisher -> Subscription callback on the Executor) next to raw Fast DDS (DataWriter ->
// DataReaderListener) with the same QoS profile, in one process and across two (the bench
// re-executes itself as the echo).
//
// The runtime/raw comparison is made trustworthy on a shared machine by alternating them:
// `--rounds` rounds, each a block of `--per-round` ping-pongs through raw DDS then one
// through the runtime (the order flips every round), so load drifts hit both alike. Each
// round trip is one sample; the tables give median, p90, p99 and mean of one-way latency
// (round trip / 2, stamped inside the ping's callback, so the waking of the measuring
// thread is not counted) and their runtime/raw ratios, plus the CPU time both processes
// spent per round trip. Throughput alternates the same way.
//
// Google Benchmark runs the hand-off floor first: a bare condition-variable ping-pong
// between two threads (what any thread hand-off costs on this machine) and the same with a
// polling receiver.
//
//   bench_runtime [--qos sensor|graph] [--rounds N] [--per-round M] [--skip-throughput]
//                 [--processes 1|2] [--benchmark_filter=...]

#include <benchmark/benchmark.h>

#include "runtime_bench_nodes.h"

namespace {

using namespace storey::bench;  // NOLINT: the bench's own nodes

// ---- A/B latency ---------------------------------------------------------------------

// One side of the comparison: a ping node, its arrivals and (two processes) the echo child.
struct LatencySide {
  std::string name;
  Arrivals arrivals;
  std::unique_ptr<Context> context;
  std::unique_ptr<EchoProcess> echo_process;
  std::unique_ptr<RuntimeNode> runtime_echo, runtime_ping;
  std::unique_ptr<RawNode> raw_echo, raw_ping;
  std::vector<double> one_way_us;
  double cpu_s = 0;
  long round_trips = 0, lost = 0;

  LatencySide(bool runtime, bool two_processes, int domain) {
    name = runtime ? "runtime" : "raw DDS";
    if (two_processes) {
      echo_process = std::make_unique<EchoProcess>(runtime ? "runtime" : "raw", domain);
    }
    if (runtime) {
      context = makeContext(domain);
      if (!two_processes) {
        runtime_echo = std::make_unique<RuntimeNode>(*context, "pong", "ping", true, nullptr);
      }
      runtime_ping = std::make_unique<RuntimeNode>(*context, "ping", "pong", false, &arrivals);
    } else {
      if (!two_processes)
        raw_echo = std::make_unique<RawNode>(domain, "pong", "ping", true, nullptr);
      raw_ping = std::make_unique<RawNode>(domain, "ping", "pong", false, &arrivals);
    }
  }
  bool waitMatched() {
    return runtime_ping ? runtime_ping->waitMatched(10) : raw_ping->waitMatched(10);
  }
  // `count` ping-pongs; recorded when `record`.
  void run(int count, bool record) {
    Scan scan = makeScan();
    const double cpu_before = processCpuSeconds();
    const double child_before = echo_process ? childCpuSeconds(echo_process->pid()) : 0;
    for (int i = 0; i < count; ++i) {
      const long target = arrivals.current() + 1;
      const auto start = Clock::now();
      if (runtime_ping) {
        runtime_ping->publish(scan);
      } else {
        raw_ping->publish(scan);
      }
      Clock::time_point stamp;
      if (!arrivals.waitFor(target, std::chrono::milliseconds(500), &stamp)) {
        if (record) ++lost;  // best effort may drop: resynchronise
        arrivals.resync(target);
        continue;
      }
      if (record)
        one_way_us.push_back(std::chrono::duration<double>(stamp - start).count() / 2 * 1e6);
    }
    if (record) {
      cpu_s += processCpuSeconds() - cpu_before;
      if (echo_process) cpu_s += childCpuSeconds(echo_process->pid()) - child_before;
      round_trips += count;
    }
  }
};

void printLatencyTable(const char* title, const LatencySide& raw, const LatencySide& runtime) {
  const Summary a = summarize(raw.one_way_us), b = summarize(runtime.one_way_us);
  const double cpu_a = raw.round_trips ? raw.cpu_s / raw.round_trips * 1e6 : 0;
  const double cpu_b = runtime.round_trips ? runtime.cpu_s / runtime.round_trips * 1e6 : 0;
  std::printf("\n%s: one-way latency, us (%zu/%zu round trips, lost %ld/%ld)\n", title,
              raw.one_way_us.size(), runtime.one_way_us.size(), raw.lost, runtime.lost);
  std::printf("%-10s %9s %9s %9s %9s %14s\n", "", "median", "p90", "p99", "mean", "cpu us/rtrip");
  std::printf("%-10s %9.1f %9.1f %9.1f %9.1f %14.1f\n", "raw DDS", a.median, a.p90, a.p99, a.mean,
              cpu_a);
  std::printf("%-10s %9.1f %9.1f %9.1f %9.1f %14.1f\n", "runtime", b.median, b.p90, b.p99, b.mean,
              cpu_b);
  std::printf("%-10s %9.2f %9.2f %9.2f %9.2f %14.2f\n", "ratio", ratio(b.median, a.median),
              ratio(b.p90, a.p90), ratio(b.p99, a.p99), ratio(b.mean, a.mean), ratio(cpu_b, cpu_a));
}

void compareLatency(bool two_processes) {
  const int domain = kDomainBase + (two_processes ? 2 : 0);
  LatencySide raw(false, two_processes, domain);
  LatencySide runtime(true, two_processes, domain + 1);
  if (!raw.waitMatched() || !runtime.waitMatched()) {
    std::printf("latency %s: endpoints did not match within 10 s\n",
                two_processes ? "2 processes" : "1 process");
    return;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  raw.run(g_settings.warmup, false);
  runtime.run(g_settings.warmup, false);
  for (int round = 0; round < g_settings.rounds; ++round) {
    LatencySide& first = round % 2 == 0 ? static_cast<LatencySide&>(raw) : runtime;
    LatencySide& second = round % 2 == 0 ? static_cast<LatencySide&>(runtime) : raw;
    first.run(10, false);  // re-warm caches after the other side's block
    first.run(g_settings.per_round, true);
    second.run(10, false);
    second.run(g_settings.per_round, true);
  }
  printLatencyTable(two_processes ? "2 processes" : "1 process", raw, runtime);
}

// ---- A/B throughput ------------------------------------------------------------------

// One process: the sender's own subscription on the same topic counts. Two processes: the
// child echoes them back and they are counted here.
struct ThroughputSide {
  Arrivals arrivals;
  std::unique_ptr<Context> context;
  std::unique_ptr<EchoProcess> echo_process;
  std::unique_ptr<RuntimeNode> runtime_node;
  std::unique_ptr<RawNode> raw_node;
  std::vector<double> rates, fractions;

  ThroughputSide(bool runtime, bool two_processes, int domain) {
    const std::string in = two_processes ? "pong" : "ping";
    if (two_processes) {
      echo_process = std::make_unique<EchoProcess>(runtime ? "runtime" : "raw", domain);
    }
    if (runtime) {
      context = makeContext(domain);
      runtime_node = std::make_unique<RuntimeNode>(*context, "ping", in, false, &arrivals);
    } else {
      raw_node = std::make_unique<RawNode>(domain, "ping", in, false, &arrivals);
    }
  }
  bool waitMatched() {
    return runtime_node ? runtime_node->waitMatched(10) : raw_node->waitMatched(10);
  }
  void blast() {
    Scan scan = makeScan();
    const long before = arrivals.current();
    const auto start = Clock::now();
    for (int i = 0; i < kThroughputBatch; ++i) {
      if (runtime_node) {
        runtime_node->publish(scan);
      } else {
        raw_node->publish(scan);
      }
    }
    // Received = what arrived until nothing more came for 100 ms.
    long seen = -1;
    while (seen != arrivals.current()) {
      seen = arrivals.current();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    Clock::time_point last;
    {
      std::lock_guard<std::mutex> lock(arrivals.mutex);
      last = arrivals.last;
    }
    const long received = arrivals.current() - before;
    const double seconds = std::chrono::duration<double>(last - start).count();
    rates.push_back(seconds > 0 ? received / seconds : 0);
    fractions.push_back(static_cast<double>(received) / kThroughputBatch);
  }
};

void compareThroughput(bool two_processes) {
  // Sides are made one after the other on one domain (a side is torn down before the
  // next starts), each round alternating which goes first.
  std::vector<double> rates[2], fractions[2];
  const int rounds = 6;
  for (int round = 0; round < rounds; ++round) {
    for (int k = 0; k < 2; ++k) {
      const bool runtime = (k == 1) != (round % 2 == 1);
      ThroughputSide side(runtime, two_processes, kDomainBase + 4);
      if (!side.waitMatched()) {
        std::printf("throughput: endpoints did not match within 10 s\n");
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      side.blast();
      rates[runtime].push_back(side.rates.back());
      fractions[runtime].push_back(side.fractions.back());
    }
  }
  const Summary a = summarize(rates[0]), b = summarize(rates[1]);
  const Summary fa = summarize(fractions[0]), fb = summarize(fractions[1]);
  std::printf("\n%s: throughput, bursts of %d scans (%d alternating rounds)\n",
              two_processes ? "2 processes" : "1 process", kThroughputBatch, rounds);
  std::printf("%-10s %12s %12s %12s %10s\n", "", "median msg/s", "min", "mean", "received");
  std::printf("%-10s %12.0f %12.0f %12.0f %10.2f\n", "raw DDS", a.median,
              *std::min_element(rates[0].begin(), rates[0].end()), a.mean, fa.median);
  std::printf("%-10s %12.0f %12.0f %12.0f %10.2f\n", "runtime", b.median,
              *std::min_element(rates[1].begin(), rates[1].end()), b.mean, fb.median);
  std::printf("%-10s %12.2f %12s %12.2f %10.2f\n", "ratio", ratio(b.median, a.median), "",
              ratio(b.mean, a.mean), ratio(fb.median, fa.median));
}

// ---- the hand-off floor (Google Benchmark) ---------------------------------------------

// Two threads bouncing a token through a mutex + condition variable: the price of any
// thread hand-off that sleeps, which the runtime pays where raw DDS calls back in place.
void BM_HandoffCondvar(benchmark::State& state) {
  std::mutex mutex;
  std::condition_variable cv;
  long token = 0;  // odd: the echo's turn
  bool stop = false;
  std::thread echo([&] {
    std::unique_lock<std::mutex> lock(mutex);
    for (;;) {
      cv.wait(lock, [&] { return stop || token % 2 == 1; });
      if (stop) return;
      ++token;
      cv.notify_all();
    }
  });
  std::vector<double> one_way;
  for (auto _ : state) {
    const auto start = Clock::now();
    std::unique_lock<std::mutex> lock(mutex);
    ++token;
    cv.notify_all();
    cv.wait(lock, [&] { return token % 2 == 0; });
    const double s = std::chrono::duration<double>(Clock::now() - start).count() / 2;
    state.SetIterationTime(s);
    one_way.push_back(s * 1e6);
  }
  {
    std::lock_guard<std::mutex> lock(mutex);
    stop = true;
  }
  cv.notify_all();
  echo.join();
  const Summary s = summarize(one_way);
  state.counters["median_us"] = s.median;
  state.counters["p90_us"] = s.p90;
  state.counters["p99_us"] = s.p99;
}

// The same with both threads polling an atomic (no sleep, no futex): the floor of a
// hand-off whose receiver is already spinning.
void BM_HandoffSpin(benchmark::State& state) {
  std::atomic<long> token{0};
  std::atomic<bool> stop{false};
  std::thread echo([&] {
    long seen = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      const long t = token.load(std::memory_order_acquire);
      if (t % 2 == 1 && t != seen) {
        seen = t + 1;
        token.store(t + 1, std::memory_order_release);
      }
    }
  });
  std::vector<double> one_way;
  for (auto _ : state) {
    const auto start = Clock::now();
    const long t = token.load() + 1;
    token.store(t, std::memory_order_release);
    while (token.load(std::memory_order_acquire) == t) {
    }
    const double s = std::chrono::duration<double>(Clock::now() - start).count() / 2;
    state.SetIterationTime(s);
    one_way.push_back(s * 1e6);
  }
  stop = true;
  echo.join();
  const Summary s = summarize(one_way);
  state.counters["median_us"] = s.median;
  state.counters["p90_us"] = s.p90;
  state.counters["p99_us"] = s.p99;
}

// The same polling hand-off carrying a LaserScan's worth of data (4320 bytes written by one
// thread, copied out by the other, and back): the cost of moving a message between cores,
// which a sample delivered on one thread and used on another always pays.
void BM_HandoffSpinScan(benchmark::State& state) {
  constexpr std::size_t kBytes = kBeams * 4;
  std::vector<char> shared(kBytes), echo_copy(kBytes), ping_copy(kBytes);
  std::atomic<long> token{0};
  std::atomic<bool> stop{false};
  std::thread echo([&] {
    long seen = 0;
    while (!stop.load(std::memory_order_relaxed)) {
      const long t = token.load(std::memory_order_acquire);
      if (t % 2 == 1 && t != seen) {
        std::memcpy(echo_copy.data(), shared.data(), kBytes);  // take
        echo_copy[t % kBytes] ^= 1;
        std::memcpy(shared.data(), echo_copy.data(), kBytes);  // publish back
        seen = t + 1;
        token.store(t + 1, std::memory_order_release);
      }
    }
  });
  std::vector<double> one_way;
  for (auto _ : state) {
    const auto start = Clock::now();
    std::memset(shared.data(), static_cast<int>(one_way.size() & 0x7f), kBytes);
    const long t = token.load() + 1;
    token.store(t, std::memory_order_release);
    while (token.load(std::memory_order_acquire) == t) {
    }
    std::memcpy(ping_copy.data(), shared.data(), kBytes);
    const double s = std::chrono::duration<double>(Clock::now() - start).count() / 2;
    state.SetIterationTime(s);
    one_way.push_back(s * 1e6);
  }
  stop = true;
  echo.join();
  const Summary s = summarize(one_way);
  state.counters["median_us"] = s.median;
  state.counters["p90_us"] = s.p90;
  state.counters["p99_us"] = s.p99;
}

BENCHMARK(BM_HandoffCondvar)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(20000);
BENCHMARK(BM_HandoffSpin)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(20000);
BENCHMARK(BM_HandoffSpinScan)->UseManualTime()->Unit(benchmark::kMicrosecond)->Iterations(20000);

bool parseInt(const char* text, int min, int* out) {
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (*end != '\0' || v < min || v > 1000000) return false;
  *out = static_cast<int>(v);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 5 && std::strcmp(argv[1], "--echo") == 0) {
    g_settings.kind = std::strcmp(argv[4], "graph") == 0 ? TopicKind::kGraph : TopicKind::kSensor;
    return runEcho(argv[2], std::atoi(argv[3]));
  }
  char path[4096];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof(path) - 1);
  if (n > 0) {
    path[n] = '\0';
    g_self = path;
  }
  // Our own options, removed before Google Benchmark sees the arguments.
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    bool ok = true;
    if (arg == "--qos" && has_value) {
      const std::string v = argv[++i];
      ok = v == "sensor" || v == "graph";
      g_settings.kind = v == "graph" ? TopicKind::kGraph : TopicKind::kSensor;
    } else if (arg == "--rounds" && has_value) {
      ok = parseInt(argv[++i], 2, &g_settings.rounds);
    } else if (arg == "--per-round" && has_value) {
      ok = parseInt(argv[++i], 1, &g_settings.per_round);
    } else if (arg == "--processes" && has_value) {
      ok = parseInt(argv[++i], 1, &g_settings.processes) && g_settings.processes <= 2;
    } else if (arg == "--skip-throughput") {
      g_settings.throughput = false;
    } else {
      argv[out++] = argv[i];
      continue;
    }
    if (!ok) {
      std::fprintf(stderr, "bench_runtime: bad value for %s: %s\n", arg.c_str(), argv[i]);
      return 2;
    }
  }
  argc = out;
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  fdds::DomainParticipantFactory::get_instance()->load_XML_profiles_file(STOREY_QOS_FILE);
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  std::printf(
      "\nQoS profile %s; LaserScan with %d beams (%d bytes of ranges); load average %.2f %.2f "
      "%.2f\n",
      Context::profileName(g_settings.kind, true).c_str(), kBeams, kBeams * 4, load[0], load[1],
      load[2]);
  std::printf("latency: %d alternating rounds of %d ping-pongs per side, after %d warm-up\n",
              g_settings.rounds, g_settings.per_round, g_settings.warmup);
  if (g_settings.processes != 2) compareLatency(false);
  if (g_settings.processes != 1) compareLatency(true);
  if (g_settings.throughput) {
    compareThroughput(false);
    compareThroughput(true);
  }
  getloadavg(load, 3);
  std::printf("\nload average at the end %.2f %.2f %.2f\n", load[0], load[1], load[2]);
  return 0;
}
