// One DDS DomainParticipant per process, plus the Executor that runs all callbacks.
// Context owns the DDS publisher/subscriber, registers each type once and creates one
// Topic per name; everything it created is torn down in the destructor.
#pragma once

#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "storey/runtime/dds.h"
#include "storey/runtime/executor.h"
#include "storey/runtime/security.h"

namespace storey::runtime {

// Thrown when a DDS entity cannot be created; what() names the entity and the topic.
class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Which QoS profile (config/dds/qos_profiles.xml) a topic uses.
enum class TopicKind {
  kSensor,  // best effort, volatile, keep last
  kGraph,   // reliable, transient local, keep all
  kLatest,  // the graph profile keeping only the last sample (a latched map, a pose, /tf)
};

// The participant profile a QoS file may hold for every storey participant (the fault
// tests' file sets UDP only and a 3 s lease); without it, Fast DDS' defaults.
inline constexpr const char* kParticipantProfile = "storey_participant";

struct ContextOptions {
  // < 0: ROS_DOMAIN_ID from the environment, else 0.
  int domain_id = -1;
  // QoS profiles; empty: STOREY_QOS_PROFILES from the environment, else the source
  // tree's config/dds/qos_profiles.xml, else the installed one.
  std::string qos_profiles_file;
  std::string participant_name = "storey";
  int executor_threads = 1;
  // DDS Security (storey/runtime/security.h); all paths empty: an unsecured participant.
  SecurityOptions security;
  // For offline jobs (storey map, experiments): a participant that discovers nobody and
  // that nobody discovers, so a replay or a live robot on the same domain can neither
  // feed it nor hear it. UDP on 127.0.0.1 only (no shared memory), no multicast and no
  // initial peers, every other participant ignored (other hosts, other processes and
  // this process alike), and its publisher and subscriber in a partition of their own.
  // Its own writers and readers still match each other (delivered within the process).
  // STOREY_SECURITY_DIR is not applied to it.
  bool isolated = false;
};

// The domain id ContextOptions{domain_id} resolves to (environment included).
int resolveDomainId(int requested);

// A DDS writer the participant discovered, with the QoS it offers.
struct DiscoveredWriter {
  std::string topic;  // DDS name, "rt/robot1/odom"
  std::string type;   // DDS type name
  bool reliable = false;
  bool transient_local = false;  // transient local or a stronger durability
};

class DiscoveryListener;

class Context {
 public:
  explicit Context(const ContextOptions& options = {});
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  int domainId() const { return domain_id_; }
  bool isolated() const { return isolated_; }
  Executor& executor() { return *executor_; }
  eprosima::fastdds::dds::DomainParticipant& participant() { return *participant_; }

  // ROS 2 naming: topic "scan" or "/robot1/scan" becomes DDS topic "rt/scan" /
  // "rt/robot1/scan".
  static std::string ddsTopicName(const std::string& name);

  // Creates a writer/reader on topic `name` (ROS 2 name) of type PubSubT. The returned
  // entities belong to this Context; release them with deleteWriter/deleteReader.
  template <typename PubSubT>
  eprosima::fastdds::dds::DataWriter* createWriter(const std::string& name, TopicKind kind) {
    return createWriter(name, kind, [] { return new PubSubT(); });
  }
  template <typename PubSubT>
  eprosima::fastdds::dds::DataReader* createReader(const std::string& name, TopicKind kind,
                                                   eprosima::fastdds::dds::DataReaderListener* l) {
    return createReader(
        name, kind, [] { return new PubSubT(); }, l);
  }
  void deleteWriter(eprosima::fastdds::dds::DataWriter* writer);
  void deleteReader(eprosima::fastdds::dds::DataReader* reader);

  // Asks whoever runs this process (the runner) to shut down; see waitForShutdownRequest.
  void requestShutdown();
  bool shutdownRequested() const;
  // Waits up to timeout_s for requestShutdown(); returns whether it was requested.
  bool waitForShutdownRequest(double timeout_s);

  static std::string profileName(TopicKind kind, bool writer);

  // Every writer discovered since the participant started (those gone since included), in
  // discovery order.
  std::vector<DiscoveredWriter> discoveredWriters() const;
  // Waits up to timeout_s until done(discoveredWriters()) holds; returns the writers then.
  std::vector<DiscoveredWriter> waitForWriters(
      const std::function<bool(const std::vector<DiscoveredWriter>&)>& done, double timeout_s);

 private:
  using TypeFactory = std::function<eprosima::fastdds::dds::TopicDataType*()>;
  eprosima::fastdds::dds::Topic* topicFor(const std::string& name, const TypeFactory& factory);
  eprosima::fastdds::dds::DataWriter* createWriter(const std::string& name, TopicKind kind,
                                                   const TypeFactory& factory);
  eprosima::fastdds::dds::DataReader* createReader(const std::string& name, TopicKind kind,
                                                   const TypeFactory& factory,
                                                   eprosima::fastdds::dds::DataReaderListener* l);

  int domain_id_ = 0;
  bool isolated_ = false;
  std::unique_ptr<Executor> executor_;
  // Declared before participant_: it must outlive the participant that calls it.
  std::unique_ptr<DiscoveryListener> discovery_listener_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;  // guards topics_ and entity creation
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
  mutable std::mutex shutdown_mutex_;
  std::condition_variable shutdown_cv_;
  bool shutdown_requested_ = false;
};

}  // namespace storey::runtime
