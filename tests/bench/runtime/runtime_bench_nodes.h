// The nodes of the runtime bench: a raw Fast DDS node, a runtime node, the echo child
// process, arrival counting and the statistics of the samples.
#pragma once

#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/runtime/context.h"
#include "storey/runtime/dds.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/signals.h"
#include "storey/runtime/subscription.h"

namespace storey::bench {

namespace fdds = eprosima::fastdds::dds;
using Scan = sensor_msgs::msg::LaserScan;
using ScanType = sensor_msgs::msg::LaserScanPubSubType;
using storey::runtime::Context;
using storey::runtime::TopicKind;
using Clock = std::chrono::steady_clock;

constexpr int kBeams = 1080;
constexpr int kThroughputBatch = 2000;
// Domain ids (the ports of ids above 232 overflow): 180/181 one process raw/runtime,
// 182/183 two processes, 184 throughput.
constexpr int kDomainBase = 180;

struct Settings {
  TopicKind kind = TopicKind::kSensor;
  int rounds = 20;
  int per_round = 250;
  int warmup = 300;
  bool throughput = true;
  int processes = 0;  // 1 or 2: only that latency comparison (for profiling); 0: both
};
inline Settings g_settings;
inline std::string g_self;

inline Scan makeScan() {
  Scan scan;
  scan.header().frame_id("laser");
  scan.angle_min(-2.35f);
  scan.angle_max(2.35f);
  scan.angle_increment(4.7f / kBeams);
  scan.range_max(30.f);
  scan.ranges().assign(kBeams, 4.2f);
  return scan;
}

inline double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

// utime + stime of another process, from /proc (clock-tick resolution).
inline double childCpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(in, line);
  const auto close = line.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(line.substr(close + 2));
  std::string skip;
  for (int i = 3; i < 14; ++i) fields >> skip;  // fields 3..13
  double utime = 0, stime = 0;
  fields >> utime >> stime;
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// Counts arrivals and stamps the last one in the receiving callback; the ping side waits.
struct Arrivals {
  std::mutex mutex;
  std::condition_variable cv;
  long count = 0;
  Clock::time_point last;
  void arrived() {
    const auto now = Clock::now();
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++count;
      last = now;
    }
    cv.notify_all();
  }
  long current() {
    std::lock_guard<std::mutex> lock(mutex);
    return count;
  }
  // The stamp of arrival number `target`, or nullopt-like false on timeout.
  bool waitFor(long target, std::chrono::milliseconds timeout, Clock::time_point* stamp) {
    std::unique_lock<std::mutex> lock(mutex);
    if (!cv.wait_for(lock, timeout, [&] { return count >= target; })) return false;
    if (stamp) *stamp = last;
    return true;
  }
  void resync(long target) {
    std::lock_guard<std::mutex> lock(mutex);
    count = std::max(count, target);
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
    const TopicKind kind = g_settings.kind;
    writer_ = pub->create_datawriter_with_profile(out_topic, Context::profileName(kind, true));
    reader_ =
        sub->create_datareader_with_profile(in_topic, Context::profileName(kind, false), this);
    if (!writer_ || !reader_) throw std::runtime_error("raw: cannot create the DDS entities");
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

inline std::unique_ptr<Context> makeContext(int domain) {
  storey::runtime::ContextOptions options;
  options.domain_id = domain;
  return std::make_unique<Context>(options);
}

struct RuntimeNode {
  RuntimeNode(Context& context, const std::string& out, const std::string& in, bool echo,
              Arrivals* arrivals)
      : publisher(context, out, g_settings.kind),
        subscription(context, in, g_settings.kind, [this, echo, arrivals](const Scan& scan) {
          if (echo) publisher.publish(scan);
          if (arrivals) arrivals->arrived();
        }) {}
  void publish(Scan& scan) { publisher.publish(scan); }
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

// Echoes ping -> pong until SIGTERM (taken with sigtimedwait, so DDS shuts down cleanly).
inline int runEcho(const std::string& mode, int domain) {
  storey::runtime::BlockedTerminationSignals signals;
  if (mode == "raw") {
    fdds::DomainParticipantFactory::get_instance()->load_XML_profiles_file(STOREY_QOS_FILE);
    RawNode node(domain, "pong", "ping", true, nullptr);
    while (signals.wait(1.0) == 0) {
    }
  } else {
    auto context = makeContext(domain);
    RuntimeNode node(*context, "pong", "ping", true, nullptr);
    while (signals.wait(1.0) == 0) {
    }
  }
  return 0;
}

// A child process running the echo until it is destroyed.
class EchoProcess {
 public:
  EchoProcess(const std::string& mode, int domain) {
    pid_ = fork();
    if (pid_ == 0) {
      const std::string d = std::to_string(domain);
      execl(g_self.c_str(), g_self.c_str(), "--echo", mode.c_str(), d.c_str(),
            g_settings.kind == TopicKind::kSensor ? "sensor" : "graph", nullptr);
      _exit(127);
    }
  }
  ~EchoProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
};

// ---- statistics ----------------------------------------------------------------------

struct Summary {
  double median = 0, p90 = 0, p99 = 0, mean = 0;
};

inline Summary summarize(std::vector<double> values) {
  Summary s;
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  const auto at = [&](double q) {
    const std::size_t i = static_cast<std::size_t>(q * (values.size() - 1) + 0.5);
    return values[std::min(i, values.size() - 1)];
  };
  s.median = at(0.5);
  s.p90 = at(0.9);
  s.p99 = at(0.99);
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / values.size();
  return s;
}

inline double ratio(double a, double b) { return b > 0 ? a / b : 0.0; }

}  // namespace storey::bench
