#include "storey/runtime/context.h"

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "storey/common/log.h"

namespace fdds = eprosima::fastdds::dds;

namespace storey::runtime {
namespace {

bool fileExists(const std::string& path) { return std::ifstream(path).good(); }

std::string resolveQosFile(const std::string& requested) {
  if (!requested.empty()) return requested;
  if (const char* env = std::getenv("STOREY_QOS_PROFILES"); env && *env) return env;
  if (fileExists(STOREY_SOURCE_QOS_FILE)) return STOREY_SOURCE_QOS_FILE;
  return STOREY_INSTALLED_QOS_FILE;
}

// The factory is process-wide: load each profile file once.
void loadQosProfiles(const std::string& path) {
  static std::mutex mutex;
  static std::set<std::string> loaded;
  std::lock_guard<std::mutex> lock(mutex);
  if (loaded.count(path)) return;
  if (!fileExists(path)) throw DdsError("QoS profile file " + path + " does not exist");
  if (fdds::DomainParticipantFactory::get_instance()->load_XML_profiles_file(path) !=
      ReturnCode_t::RETCODE_OK) {
    throw DdsError("cannot load the QoS profiles in " + path);
  }
  loaded.insert(path);
}

// See ContextOptions::isolated. Fast DDS adds the domain's multicast locators only when
// no metatraffic locator is given, and announces to its multicast locators when no
// initial peer is given: one unicast locator on 127.0.0.1 leaves nothing to announce to.
void isolate(fdds::DomainParticipantQos& qos) {
  namespace rtps = eprosima::fastrtps::rtps;
  qos.transport().use_builtin_transports = false;
  qos.transport().user_transports.clear();
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList = {"127.0.0.1"};
  qos.transport().user_transports.push_back(udp);
  rtps::Locator_t loopback;
  loopback.kind = LOCATOR_KIND_UDPv4;
  rtps::IPLocator::setIPv4(loopback, 127, 0, 0, 1);
  auto& builtin = qos.wire_protocol().builtin;
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(loopback);
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.initialPeersList.clear();
  qos.wire_protocol().default_unicast_locator_list.clear();
  qos.wire_protocol().default_unicast_locator_list.push_back(loopback);
  qos.wire_protocol().default_multicast_locator_list.clear();
  using Filter = rtps::ParticipantFilteringFlags_t;
  builtin.discovery_config.ignoreParticipantFlags =
      static_cast<Filter>(Filter::FILTER_DIFFERENT_HOST | Filter::FILTER_DIFFERENT_PROCESS |
                          Filter::FILTER_SAME_PROCESS);
}

// A partition no other participant uses: a second guard should one be matched anyway.
std::string isolatedPartition() {
  static std::atomic<unsigned> next{0};
  return "storey_isolated_" + std::to_string(::getpid()) + "_" + std::to_string(next++);
}

// Explicit options win; else STOREY_SECURITY_DIR names a security folder in which this
// participant (by name) has its identity, so a whole `storey launch` can be secured.
SecurityOptions resolveSecurity(const ContextOptions& options) {
  if (options.security.enabled() || options.isolated) return options.security;
  const char* dir = std::getenv("STOREY_SECURITY_DIR");
  if (!dir || !*dir) return {};
  try {
    return securityFromFolder(dir, options.participant_name);
  } catch (const std::exception& e) {
    throw DdsError(std::string("STOREY_SECURITY_DIR: ") + e.what());
  }
}

}  // namespace

// Logs (debug) every remote participant this one discovers, drops or loses, so a process
// that matches nobody can be told apart from one that matched and got nothing; and keeps
// every writer discovered, with its QoS (what `storey record` stores as offered).
class DiscoveryListener : public fdds::DomainParticipantListener {
 public:
  void on_participant_discovery(fdds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    using Info = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
    const char* what = info.status == Info::DISCOVERED_PARTICIPANT  ? "discovered"
                       : info.status == Info::REMOVED_PARTICIPANT   ? "removed"
                       : info.status == Info::DROPPED_PARTICIPANT   ? "dropped (lease expired)"
                                                                    : "changed";
    common::logDebug(common::str("dds: participant ", participant->get_qos().name().to_string(), " (",
                                 participant->guid().guidPrefix, ") ", what, " participant ",
                                 info.info.m_participantName.to_string(), " (",
                                 info.info.m_guid.guidPrefix, ")"));
  }

  void on_publisher_discovery(fdds::DomainParticipant*,
                              eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    using Info = eprosima::fastrtps::rtps::WriterDiscoveryInfo;
    if (info.status != Info::DISCOVERED_WRITER && info.status != Info::CHANGED_QOS_WRITER) return;
    DiscoveredWriter writer;
    writer.topic = info.info.topicName().to_string();
    writer.type = info.info.typeName().to_string();
    writer.reliable = info.info.m_qos.m_reliability.kind == fdds::RELIABLE_RELIABILITY_QOS;
    writer.transient_local = info.info.m_qos.m_durability.kind != fdds::VOLATILE_DURABILITY_QOS;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      std::ostringstream guid;
      guid << info.info.guid();
      const auto [it, added] = index_.emplace(guid.str(), writers_.size());
      if (added) {
        writers_.push_back(std::move(writer));
      } else {
        writers_[it->second] = std::move(writer);
      }
    }
    changed_.notify_all();
  }

  std::vector<DiscoveredWriter> writers() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return writers_;
  }

  std::vector<DiscoveredWriter> waitFor(
      const std::function<bool(const std::vector<DiscoveredWriter>&)>& done, double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                      [&] { return done(writers_); });
    return writers_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<DiscoveredWriter> writers_;
  std::map<std::string, std::size_t> index_;  // GUID -> position in writers_
};

// TopicKind::kLatest: a graph profile's reader or writer QoS with a history of one.
template <typename Qos>
void keepOnlyTheLast(Qos& qos) {
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
}

int resolveDomainId(int requested) {
  if (requested >= 0) return requested;
  const char* env = std::getenv("ROS_DOMAIN_ID");
  if (!env || !*env) return 0;
  char* end = nullptr;
  const long value = std::strtol(env, &end, 10);
  if (*end != '\0' || value < 0 || value > 232) {
    throw DdsError(std::string("ROS_DOMAIN_ID='") + env + "' is not a domain id in [0, 232]");
  }
  return static_cast<int>(value);
}

std::string Context::profileName(TopicKind kind, bool writer) {
  // kLatest is the graph profile with a history of one (set where it is created).
  const std::string base = kind == TopicKind::kSensor ? "storey_sensor_" : "storey_graph_";
  return base + (writer ? "writer" : "reader");
}

std::string Context::ddsTopicName(const std::string& name) {
  if (name.empty()) throw DdsError("empty topic name");
  return "rt/" + (name.front() == '/' ? name.substr(1) : name);
}

Context::Context(const ContextOptions& options) {
  domain_id_ = resolveDomainId(options.domain_id);
  const std::string qos_file = resolveQosFile(options.qos_profiles_file);
  loadQosProfiles(qos_file);
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  // A participant profile named kParticipantProfile in the file, if there is one (its
  // transports, discovery lease). Fast DDS 2.9 does not apply a file's
  // is_default_profile participant to the default QoS, so it is looked up by name.
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  factory->get_participant_qos_from_profile(kParticipantProfile, qos);
  qos.name(options.participant_name);
  isolated_ = options.isolated;
  if (isolated_) isolate(qos);
  const SecurityOptions security = resolveSecurity(options);
  for (const auto& [name, value] : securityProperties(security)) {
    qos.properties().properties().emplace_back(name, value);
  }
  discovery_listener_ = std::make_unique<DiscoveryListener>();
  // Discovery callbacks do not depend on the mask; none keeps every other status on the
  // entities' own listeners.
  participant_ = factory->create_participant(domain_id_, qos, discovery_listener_.get(),
                                             fdds::StatusMask::none());
  if (!participant_) {
    std::string why;
    if (security.enabled()) {
      why = diagnoseSecurityFiles(security);
      why =
          why.empty()
              ? " (security enabled: check the identity, governance and permissions files and that "
                "they are signed by the given CAs)"
              : ": security check failed: " + why;
    }
    throw DdsError("cannot create a DomainParticipant on domain " + std::to_string(domain_id_) +
                   why);
  }
  fdds::PublisherQos publisher_qos = fdds::PUBLISHER_QOS_DEFAULT;
  fdds::SubscriberQos subscriber_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
  if (isolated_) {
    const std::string partition = isolatedPartition();
    publisher_qos.partition().push_back(partition.c_str());
    subscriber_qos.partition().push_back(partition.c_str());
  }
  publisher_ = participant_->create_publisher(publisher_qos);
  subscriber_ = participant_->create_subscriber(subscriber_qos);
  if (!publisher_ || !subscriber_) {
    participant_->delete_contained_entities();
    factory->delete_participant(participant_);
    throw DdsError("cannot create the DDS publisher/subscriber");
  }
  executor_ = std::make_unique<Executor>(options.executor_threads);
}

Context::~Context() {
  // Callbacks first: no task may touch a reader while it is being deleted.
  executor_->shutdown();
  if (participant_) {
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
}

std::vector<DiscoveredWriter> Context::discoveredWriters() const {
  return discovery_listener_->writers();
}

std::vector<DiscoveredWriter> Context::waitForWriters(
    const std::function<bool(const std::vector<DiscoveredWriter>&)>& done, double timeout_s) {
  return discovery_listener_->waitFor(done, timeout_s);
}

fdds::Topic* Context::topicFor(const std::string& name, const TypeFactory& factory) {
  const std::string dds_name = ddsTopicName(name);
  fdds::TypeSupport type(factory());
  const std::string type_name = type.get_type_name();
  auto it = topics_.find(dds_name);
  if (it != topics_.end()) {
    if (it->second->get_type_name() != type_name) {
      throw DdsError("topic " + name + " already has type " + it->second->get_type_name() +
                     ", not " + type_name);
    }
    return it->second;
  }
  if (participant_->find_type(type_name).empty() &&
      type.register_type(participant_) != ReturnCode_t::RETCODE_OK) {
    throw DdsError("cannot register type " + type_name);
  }
  fdds::Topic* topic = participant_->create_topic(dds_name, type_name, fdds::TOPIC_QOS_DEFAULT);
  if (!topic) throw DdsError("cannot create topic " + dds_name + " of type " + type_name);
  topics_[dds_name] = topic;
  return topic;
}

fdds::DataWriter* Context::createWriter(const std::string& name, TopicKind kind,
                                        const TypeFactory& factory) {
  std::lock_guard<std::mutex> lock(mutex_);
  fdds::Topic* topic = topicFor(name, factory);
  const std::string profile = profileName(kind, true);
  fdds::DataWriter* writer = nullptr;
  if (kind == TopicKind::kLatest) {
    fdds::DataWriterQos qos = publisher_->get_default_datawriter_qos();
    if (publisher_->get_datawriter_qos_from_profile(profile, qos) == ReturnCode_t::RETCODE_OK) {
      keepOnlyTheLast(qos);
      writer = publisher_->create_datawriter(topic, qos);
    }
  } else {
    writer = publisher_->create_datawriter_with_profile(topic, profile);
  }
  if (!writer) throw DdsError("cannot create a writer on " + name + " with profile " + profile);
  return writer;
}

fdds::DataReader* Context::createReader(const std::string& name, TopicKind kind,
                                        const TypeFactory& factory,
                                        fdds::DataReaderListener* listener) {
  std::lock_guard<std::mutex> lock(mutex_);
  fdds::Topic* topic = topicFor(name, factory);
  const std::string profile = profileName(kind, false);
  const fdds::StatusMask mask = fdds::StatusMask::data_available()
                                << fdds::StatusMask::subscription_matched();
  fdds::DataReader* reader = nullptr;
  if (kind == TopicKind::kLatest) {
    fdds::DataReaderQos qos = subscriber_->get_default_datareader_qos();
    if (subscriber_->get_datareader_qos_from_profile(profile, qos) == ReturnCode_t::RETCODE_OK) {
      keepOnlyTheLast(qos);
      reader = subscriber_->create_datareader(topic, qos, listener, mask);
    }
  } else {
    reader = subscriber_->create_datareader_with_profile(topic, profile, listener, mask);
  }
  if (!reader) throw DdsError("cannot create a reader on " + name + " with profile " + profile);
  return reader;
}

void Context::deleteWriter(fdds::DataWriter* writer) {
  if (!writer) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (publisher_->delete_datawriter(writer) != ReturnCode_t::RETCODE_OK) {
    common::logWarn("cannot delete a DDS writer");
  }
}

void Context::deleteReader(fdds::DataReader* reader) {
  if (!reader) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (subscriber_->delete_datareader(reader) != ReturnCode_t::RETCODE_OK) {
    common::logWarn("cannot delete a DDS reader");
  }
}

void Context::requestShutdown() {
  {
    std::lock_guard<std::mutex> lock(shutdown_mutex_);
    shutdown_requested_ = true;
  }
  shutdown_cv_.notify_all();
}

bool Context::shutdownRequested() const {
  std::lock_guard<std::mutex> lock(shutdown_mutex_);
  return shutdown_requested_;
}

bool Context::waitForShutdownRequest(double timeout_s) {
  std::unique_lock<std::mutex> lock(shutdown_mutex_);
  return shutdown_cv_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                               [&] { return shutdown_requested_; });
}

}  // namespace storey::runtime
