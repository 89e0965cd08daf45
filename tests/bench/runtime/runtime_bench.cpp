// End-to-end latency (ping-pong, one way = round trip / 2) and throughput of a 1080-beam
// LaserScan through storey's runtime (Publisher -> Subscription callback on the Executor)
// and through raw Fast DDS (DataWriter -> DataReaderListener), with the same QoS profile,
// in one process and across two processes (the bench re-executes itself as the echo).
// Prints a table with the runtime/raw ratios after the benchmarks.
//
//   bench_runtime [--benchmark_filter=...] [--qos sensor|graph]
#include <benchmark/benchmark.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/runtime/context.h"
#include "storey/runtime/dds.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/signals.h"
#include "storey/runtime/subscription.h"

namespace {

namespace fdds = eprosima::fastdds::dds;
using Scan = sensor_msgs::msg::LaserScan;
using ScanType = sensor_msgs::msg::LaserScanPubSubType;
using storey::runtime::Context;
using storey::runtime::TopicKind;
using Clock = std::chrono::steady_clock;

constexpr int kBeams = 1080;
constexpr int kThroughputBatch = 2000;
TopicKind g_kind = TopicKind::kSensor;
std::string g_self;

Scan makeScan() {
  Scan scan;
  scan.header().frame_id("laser");
  scan.angle_min(-2.35f);
  scan.angle_max(2.35f);
  scan.angle_increment(4.7f / kBeams);
  scan.range_max(30.f);
  scan.ranges().assign(kBeams, 4.2f);
  return scan;
}

// Counts arrivals; the ping side waits on it.
struct Arrivals {
  std::mutex mutex;
  std::condition_variable cv;
  long count = 0;
  Clock::time_point last;
  void arrived() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++count;
      last = Clock::now();
    }
    cv.notify_all();
  }
  long current() {
    std::lock_guard<std::mutex> lock(mutex);
    return count;
  }
  bool waitFor(long target, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex);
    return cv.wait_for(lock, timeout, [&] { return count >= target; });
  }
};

// ---- raw Fast DDS --------------------------------------------------------------------

class RawNode : public fdds::DataReaderListener {
 public:
  // Writes on `out`, reads `in`; `echo` republishes each sample from the listener thread.
  RawNode(int domain, const std::string& out, const std::string& in, bool echo, Arrivals* arrivals)
      : echo_(echo), arrivals_(arrivals) {
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    participant_ = factory->create_participant(domain, factory->get_default_participant_qos());
    if (!participant_) throw std::runtime_error("raw: no participant");
    fdds::TypeSupport type(new ScanType());
    type.register_type(participant_);
    auto* pub = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    auto* sub = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    auto* out_topic = participant_->create_topic(Context::ddsTopicName(out), type.get_type_name(),
                                                 fdds::TOPIC_QOS_DEFAULT);
    auto* in_topic =
        in == out ? out_topic
                  : participant_->create_topic(Context::ddsTopicName(in), type.get_type_name(),
                                               fdds::TOPIC_QOS_DEFAULT);
    if (!pub || !sub || !out_topic || !in_topic) throw std::runtime_error("raw: no topic");
    writer_ = pub->create_datawriter_with_profile(out_topic, Context::profileName(g_kind, true));
    reader_ =
        sub->create_datareader_with_profile(in_topic, Context::profileName(g_kind, false), this);
    if (!pub || !sub || !out_topic || !in_topic || !writer_ || !reader_) {
      throw std::runtime_error("raw: cannot create the DDS entities");
    }
  }
  ~RawNode() override {
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  void on_data_available(fdds::DataReader* reader) override {
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample_, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      if (echo_) writer_->write(&sample_);
      if (arrivals_) arrivals_->arrived();
    }
  }
  void publish(Scan& scan) { writer_->write(&scan); }
  bool waitMatched(double timeout_s) {
    const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < end) {
      fdds::PublicationMatchedStatus pub_status;
      fdds::SubscriptionMatchedStatus sub_status;
      writer_->get_publication_matched_status(pub_status);
      reader_->get_subscription_matched_status(sub_status);
      if (pub_status.current_count > 0 && sub_status.current_count > 0) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

 private:
  bool echo_;
  Arrivals* arrivals_;
  Scan sample_;
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::DataWriter* writer_ = nullptr;
  fdds::DataReader* reader_ = nullptr;
};

// ---- runtime -------------------------------------------------------------------------

struct RuntimeNode {
  RuntimeNode(Context& context, const std::string& out, const std::string& in, bool echo,
              Arrivals* arrivals)
      : publisher(context, out, g_kind),
        subscription(context, in, g_kind, [this, echo, arrivals](const Scan& scan) {
          if (echo) publisher.publish(scan);
          if (arrivals) arrivals->arrived();
        }) {}
  bool waitMatched(double timeout_s) {
    if (!publisher.waitForSubscribers(1, timeout_s)) return false;
    const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (subscription.matchedCount() < 1) {
      if (Clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }
  storey::runtime::Publisher<Scan, ScanType> publisher;
  storey::runtime::Subscription<Scan, ScanType> subscription;
};

// ---- the echo process ----------------------------------------------------------------

// Echoes until SIGTERM (taken with sigtimedwait, so DDS shuts down cleanly).
int runEcho(const std::string& mode, int domain) {
  storey::runtime::BlockedTerminationSignals signals;
  if (mode == "raw") {
    fdds::DomainParticipantFactory::get_instance()->load_XML_profiles_file(STOREY_QOS_FILE);
    RawNode node(domain, "pong", "ping", true, nullptr);
    while (signals.wait(1.0) == 0) {
    }
  } else {
    storey::runtime::ContextOptions options;
    options.domain_id = domain;
    Context context(options);
    RuntimeNode node(context, "pong", "ping", true, nullptr);
    while (signals.wait(1.0) == 0) {
    }
  }
  return 0;
}

// A child process running the echo until the benchmark kills it.
class EchoProcess {
 public:
  EchoProcess(const std::string& mode, int domain) {
    pid_ = fork();
    if (pid_ == 0) {
      const std::string d = std::to_string(domain);
      execl(g_self.c_str(), g_self.c_str(), "--echo", mode.c_str(), d.c_str(),
            g_kind == TopicKind::kSensor ? "sensor" : "graph", nullptr);
      _exit(127);
    }
  }
  ~EchoProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }

 private:
  pid_t pid_ = -1;
};

// ---- benchmarks ----------------------------------------------------------------------

std::map<std::string, double> g_results;  // name -> figure, for the ratio table
std::unique_ptr<Context> g_context;       // the bench process's one participant

Context& benchContext(int domain) {
  if (!g_context || g_context->domainId() != domain) {
    g_context.reset();
    storey::runtime::ContextOptions options;
    options.domain_id = domain;
    g_context = std::make_unique<Context>(options);
  }
  return *g_context;
}

template <typename Node>
void pingPong(benchmark::State& state, Node& ping, Arrivals& arrivals, const std::string& key) {
  Scan scan = makeScan();
  double total_us = 0;
  long rounds = 0, lost = 0;
  for (auto _ : state) {
    const long target = arrivals.current() + 1;
    const auto start = Clock::now();
    ping.publish(scan);
    if (!arrivals.waitFor(target, std::chrono::milliseconds(500))) {
      ++lost;  // best effort may drop; resynchronise
      std::lock_guard<std::mutex> lock(arrivals.mutex);
      arrivals.count = target;
      state.SetIterationTime(0.5);
      continue;
    }
    const double one_way = std::chrono::duration<double>(Clock::now() - start).count() / 2;
    state.SetIterationTime(one_way);
    total_us += one_way * 1e6;
    ++rounds;
  }
  state.counters["one_way_us"] = rounds ? total_us / rounds : 0;
  state.counters["lost"] = lost;
  g_results[key] = rounds ? total_us / rounds : 0;
}

template <typename Node>
void blast(benchmark::State& state, Node& sender, Arrivals& arrivals, const std::string& key) {
  Scan scan = makeScan();
  double total_rate = 0;
  int runs = 0;
  for (auto _ : state) {
    const long before = arrivals.current();
    const auto start = Clock::now();
    for (int i = 0; i < kThroughputBatch; ++i) sender.publish(scan);
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
    state.SetIterationTime(seconds);
    total_rate += received / seconds;
    state.counters["received_fraction"] = static_cast<double>(received) / kThroughputBatch;
    ++runs;
  }
  state.counters["msgs_per_s"] = total_rate / runs;
  g_results[key] = total_rate / runs;
}

// Ping-pong latency: the echo mirrors ping -> pong in this process or in a child.
void BM_Latency(benchmark::State& state, bool runtime, bool two_processes) {
  const int domain = 180 + (runtime ? 0 : 1) + (two_processes ? 2 : 0);
  Context& context = benchContext(domain);  // also loads the QoS profiles
  Arrivals arrivals;
  std::unique_ptr<EchoProcess> echo_process;
  std::unique_ptr<RuntimeNode> runtime_echo;
  std::unique_ptr<RawNode> raw_echo;
  if (two_processes) {
    echo_process = std::make_unique<EchoProcess>(runtime ? "runtime" : "raw", domain);
  } else if (runtime) {
    runtime_echo = std::make_unique<RuntimeNode>(context, "pong", "ping", true, nullptr);
  } else {
    raw_echo = std::make_unique<RawNode>(domain, "pong", "ping", true, nullptr);
  }
  const std::string key = std::string("latency_us ") + (two_processes ? "2proc" : "1proc");
  if (runtime) {
    RuntimeNode ping(context, "ping", "pong", false, &arrivals);
    if (!ping.waitMatched(10)) return state.SkipWithError("no match");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    pingPong(state, ping.publisher, arrivals, key + " runtime");
  } else {
    RawNode ping(domain, "ping", "pong", false, &arrivals);
    if (!ping.waitMatched(10)) return state.SkipWithError("no match");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    pingPong(state, ping, arrivals, key + " raw");
  }
}

// Throughput: one sender blasts kThroughputBatch scans; the receiver is in this process or
// in a child which echoes them back (so the count is taken here).
void BM_Throughput(benchmark::State& state, bool runtime, bool two_processes) {
  const int domain = 190 + (runtime ? 0 : 1) + (two_processes ? 2 : 0);
  Context& context = benchContext(domain);
  Arrivals arrivals;
  std::unique_ptr<EchoProcess> echo_process;
  if (two_processes) {
    echo_process = std::make_unique<EchoProcess>(runtime ? "runtime" : "raw", domain);
  }
  const std::string key = std::string("msgs_per_s ") + (two_processes ? "2proc" : "1proc");
  // One process: the sender's own subscription on the same topic counts.
  const std::string in = two_processes ? "pong" : "ping";
  if (runtime) {
    RuntimeNode node(context, "ping", in, false, &arrivals);
    if (!node.waitMatched(10)) return state.SkipWithError("no match");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    blast(state, node.publisher, arrivals, key + " runtime");
  } else {
    RawNode node(domain, "ping", in, false, &arrivals);
    if (!node.waitMatched(10)) return state.SkipWithError("no match");
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    blast(state, node, arrivals, key + " raw");
  }
}

void registerBenchmarks() {
  for (bool two : {false, true}) {
    for (bool runtime : {false, true}) {
      const std::string suffix =
          std::string(runtime ? "runtime" : "raw") + (two ? "/2proc" : "/1proc");
      benchmark::RegisterBenchmark(("Latency/" + suffix).c_str(), BM_Latency, runtime, two)
          ->UseManualTime()
          ->Unit(benchmark::kMicrosecond)
          ->Iterations(2000);
      benchmark::RegisterBenchmark(("Throughput/" + suffix).c_str(), BM_Throughput, runtime, two)
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond)
          ->Iterations(5);
    }
  }
}

void printRatios() {
  std::printf("\n%-22s %12s %12s %8s\n", "figure", "runtime", "raw DDS", "ratio");
  for (const char* figure :
       {"latency_us 1proc", "latency_us 2proc", "msgs_per_s 1proc", "msgs_per_s 2proc"}) {
    const auto runtime = g_results.find(std::string(figure) + " runtime");
    const auto raw = g_results.find(std::string(figure) + " raw");
    if (runtime == g_results.end() || raw == g_results.end()) continue;
    std::printf("%-22s %12.1f %12.1f %8.2f\n", figure, runtime->second, raw->second,
                raw->second > 0 ? runtime->second / raw->second : 0.0);
  }
  std::printf("(QoS profile: %s; LaserScan with %d beams, %d bytes of ranges)\n",
              Context::profileName(g_kind, true).c_str(), kBeams, kBeams * 4);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 5 && std::strcmp(argv[1], "--echo") == 0) {
    g_kind = std::strcmp(argv[4], "graph") == 0 ? TopicKind::kGraph : TopicKind::kSensor;
    return runEcho(argv[2], std::atoi(argv[3]));
  }
  char path[4096];
  const ssize_t n = readlink("/proc/self/exe", path, sizeof(path) - 1);
  if (n > 0) {
    path[n] = '\0';
    g_self = path;
  }
  // Our own option, removed before Google Benchmark sees the arguments.
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--qos") == 0 && i + 1 < argc) {
      g_kind = std::strcmp(argv[++i], "graph") == 0 ? TopicKind::kGraph : TopicKind::kSensor;
    } else {
      argv[out++] = argv[i];
    }
  }
  argc = out;
  registerBenchmarks();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  g_context.reset();
  printRatios();
  return 0;
}
