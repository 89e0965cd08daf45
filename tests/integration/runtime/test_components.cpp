#include "test_components.h"

#include <unistd.h>

#include <csignal>
#include <fstream>

#include "storey/runtime/component.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"

namespace storey::runtime::test {
namespace {

using FloorEvent = storey_msgs::msg::FloorEvent;
using FloorEventType = storey_msgs::msg::FloorEventPubSubType;

std::mutex log_mutex;
std::vector<std::string> log_entries;

void record(const std::string& entry) {
  std::lock_guard<std::mutex> lock(log_mutex);
  log_entries.push_back(entry);
}

TopicKind readKind(const common::ConfigNode& p) {
  return p.getChoice("qos", "graph", {"sensor", "graph"}) == "sensor" ? TopicKind::kSensor
                                                                      : TopicKind::kGraph;
}

class Talker : public Component {
 public:
  using Component::Component;

 protected:
  void onConfigure() override {
    topic_ = parameters().get<std::string>("topic");
    rate_hz_ = parameters().getDouble("rate_hz", 1e-3, 1e4);
    const TopicKind kind = readKind(parameters());
    publisher_ = createPublisher<FloorEvent, FloorEventType>(topic_, kind);
    createTimer(1.0 / rate_hz_, [this] {
      FloorEvent event;
      event.robot(name());
      event.floor_id(next_++);
      publisher_->publish(event);
    });
  }
  void onCleanup() override { publisher_.reset(); }

 private:
  std::string topic_;
  double rate_hz_ = 0;
  int next_ = 0;
  std::shared_ptr<Publisher<FloorEvent, FloorEventType>> publisher_;
};

class Listener : public Component {
 public:
  using Component::Component;

 protected:
  void onConfigure() override {
    const auto topic = parameters().get<std::string>("topic");
    output_file_ = parameters().get<std::string>("output_file", "");
    finish_after_ = parameters().getInt("finish_after", 0, 0, 1000000);
    subscription_ = createSubscription<FloorEvent, FloorEventType>(
        topic, readKind(parameters()), [this](const FloorEvent& event) {
          ++received_;
          if (!output_file_.empty()) {
            std::ofstream(output_file_, std::ios::app) << event.floor_id() << "\n";
          }
          if (finish_after_ > 0 && received_ == finish_after_) requestFinish();
        });
  }
  void onCleanup() override { subscription_.reset(); }

 private:
  std::string output_file_;
  int finish_after_ = 0;
  int received_ = 0;
  std::shared_ptr<Subscription<FloorEvent, FloorEventType>> subscription_;
};

class Crasher : public Component {
 public:
  using Component::Component;

 protected:
  void onConfigure() override {
    const double after_s = parameters().getDouble("after_s", 0.001, 60);
    const int exit_code = parameters().getInt("exit_code", 1, 0, 255);
    const int signal = parameters().getInt("signal", 0, 0, 64);
    createTimer(after_s, [exit_code, signal] {
      if (signal != 0) {
        // Unblock first: the runner blocks SIGINT/SIGTERM.
        sigset_t set;
        sigemptyset(&set);
        sigaddset(&set, signal);
        pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
        raise(signal);
      }
      _exit(exit_code);
    });
  }
};

class Recorder : public Component {
 public:
  Recorder(Context& context, const common::ConfigNode& parameters, std::string name)
      : Component(context, parameters, std::move(name)) {
    record(this->name() + ":construct");
  }
  ~Recorder() override { record(name() + ":destroy"); }

 protected:
  void onConfigure() override {
    if (parameters().get<bool>("fail_configure", false)) {
      throw std::runtime_error("configure fails on purpose");
    }
    publisher_ = createPublisher<FloorEvent, FloorEventType>(
        parameters().get<std::string>("topic", "recorder"), TopicKind::kGraph);
    // Not sent: publishers are inactive until activate.
    publisher_->publish(FloorEvent());
    record(name() + ":configure");
  }
  void onActivate() override { record(name() + ":activate"); }
  void onDeactivate() override { record(name() + ":deactivate"); }
  void onCleanup() override {
    publisher_.reset();
    record(name() + ":cleanup");
  }

 private:
  std::shared_ptr<Publisher<FloorEvent, FloorEventType>> publisher_;
};

}  // namespace

ComponentRegistry testRegistry() {
  ComponentRegistry registry;
  registerTestComponents(registry);
  return registry;
}

std::vector<int> readInts(const std::string& path) {
  std::ifstream in(path);
  std::vector<int> values;
  for (int v; in >> v;) values.push_back(v);
  return values;
}

void registerTestComponents(ComponentRegistry& registry) {
  registry.add<Talker>("test_talker", "publishes FloorEvents at a rate");
  registry.add<Listener>("test_listener", "counts FloorEvents");
  registry.add<Crasher>("test_crasher", "exits or dies after a delay");
  registry.add<Recorder>("test_recorder", "records its lifecycle");
}

std::vector<std::string> lifecycleLog() {
  std::lock_guard<std::mutex> lock(log_mutex);
  return log_entries;
}

void clearLifecycleLog() {
  std::lock_guard<std::mutex> lock(log_mutex);
  log_entries.clear();
}

}  // namespace storey::runtime::test
