#include "storey/runtime/bag_recorder.h"

#include <chrono>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "geometry_msgs/msg/PoseStampedPubSubTypes.h"
#include "geometry_msgs/msg/PoseWithCovarianceStampedPubSubTypes.h"
#include "geometry_msgs/msg/TransformStampedPubSubTypes.h"
#include "nav_msgs/msg/OccupancyGridPubSubTypes.h"
#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/FluidPressurePubSubTypes.h"
#include "sensor_msgs/msg/ImuPubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/bag/metadata.h"
#include "storey/runtime/bag_cdr.h"
#include "storey/runtime/sensor_bag.h"
#include "storey_msgs/msg/BuildingStatePubSubTypes.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"
#include "storey_msgs/msg/InterFloorConstraintPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::runtime {
namespace {

using Sink = std::function<void(std::vector<std::uint8_t>&&)>;
using Subscriber =
    std::function<std::unique_ptr<SubscriptionBase>(Context&, const std::string&, TopicKind, Sink)>;

template <typename MsgT, typename PubSubT>
Subscriber subscriber() {
  return [](Context& context, const std::string& topic, TopicKind kind, Sink sink) {
    return std::make_unique<Subscription<MsgT, PubSubT>>(
        context, topic, kind,
        [sink = std::move(sink)](const MsgT& msg) { sink(serializeCdr(msg)); });
  };
}

struct KnownType {
  TopicKind kind;
  Subscriber subscribe;
};

// Sensor streams are recorded best effort (matches best-effort and reliable writers);
// storey's graph topics and maps reliable and transient local, to get their history.
const std::map<std::string, KnownType>& knownTypeTable() {
  static const std::map<std::string, KnownType> table = {
      {"sensor_msgs/msg/LaserScan",
       {TopicKind::kSensor,
        subscriber<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>()}},
      {"sensor_msgs/msg/FluidPressure",
       {TopicKind::kSensor,
        subscriber<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType>()}},
      {"sensor_msgs/msg/Imu",
       {TopicKind::kSensor, subscriber<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType>()}},
      {"nav_msgs/msg/Odometry",
       {TopicKind::kSensor,
        subscriber<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>()}},
      {"tf2_msgs/msg/TFMessage",
       {TopicKind::kSensor,
        subscriber<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>()}},
      {"geometry_msgs/msg/PoseStamped",
       {TopicKind::kSensor,
        subscriber<geometry_msgs::msg::PoseStamped, geometry_msgs::msg::PoseStampedPubSubType>()}},
      {"geometry_msgs/msg/PoseWithCovarianceStamped",
       {TopicKind::kSensor, subscriber<geometry_msgs::msg::PoseWithCovarianceStamped,
                                       geometry_msgs::msg::PoseWithCovarianceStampedPubSubType>()}},
      {"geometry_msgs/msg/TransformStamped",
       {TopicKind::kSensor, subscriber<geometry_msgs::msg::TransformStamped,
                                       geometry_msgs::msg::TransformStampedPubSubType>()}},
      {"nav_msgs/msg/OccupancyGrid",
       {TopicKind::kGraph,
        subscriber<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>()}},
      {"storey_msgs/msg/FloorEvent",
       {TopicKind::kGraph,
        subscriber<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>()}},
      {"storey_msgs/msg/FloorGraphUpdate",
       {TopicKind::kGraph, subscriber<storey_msgs::msg::FloorGraphUpdate,
                                      storey_msgs::msg::FloorGraphUpdatePubSubType>()}},
      {"storey_msgs/msg/InterFloorConstraint",
       {TopicKind::kGraph, subscriber<storey_msgs::msg::InterFloorConstraint,
                                      storey_msgs::msg::InterFloorConstraintPubSubType>()}},
      {"storey_msgs/msg/BuildingState",
       {TopicKind::kGraph,
        subscriber<storey_msgs::msg::BuildingState, storey_msgs::msg::BuildingStatePubSubType>()}},
  };
  return table;
}

std::string joinedKnownTypes() {
  std::string out;
  for (const auto& [name, type] : knownTypeTable()) out += (out.empty() ? "" : ", ") + name;
  return out;
}

std::int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::vector<std::string> BagRecorder::knownTypes() {
  std::vector<std::string> names;
  for (const auto& [name, type] : knownTypeTable()) names.push_back(name);
  return names;
}

std::string BagRecorder::inferType(const std::string& topic_name) {
  const std::string leaf = topic_name.substr(topic_name.rfind('/') + 1);
  if (leaf == "scan") return "sensor_msgs/msg/LaserScan";
  if (leaf == "odom") return "nav_msgs/msg/Odometry";
  if (leaf == "pressure") return "sensor_msgs/msg/FluidPressure";
  if (leaf == "imu") return "sensor_msgs/msg/Imu";
  if (leaf == "tf" || leaf == "tf_static") return "tf2_msgs/msg/TFMessage";
  return "";
}

std::vector<RecordTopic> parseRecordTopics(const std::string& list) {
  std::vector<RecordTopic> topics;
  std::stringstream in(list);
  std::string entry;
  while (std::getline(in, entry, ',')) {
    if (entry.empty()) continue;
    RecordTopic topic;
    const auto colon = entry.find(':');
    topic.name = entry.substr(0, colon);
    if (!topic.name.empty() && topic.name.front() != '/') topic.name = "/" + topic.name;
    topic.type =
        colon == std::string::npos ? BagRecorder::inferType(topic.name) : entry.substr(colon + 1);
    if (topic.name.size() < 2) {
      throw std::invalid_argument("topic entry '" + entry + "' has no name");
    }
    if (!topic.type.empty() && !knownTypeTable().count(topic.type)) {
      throw std::invalid_argument("topic '" + topic.name + "': type '" + topic.type +
                                  "' is not one storey can record; known: " + joinedKnownTypes());
    }
    for (const RecordTopic& other : topics) {
      if (other.name == topic.name) {
        throw std::invalid_argument("topic '" + topic.name + "' is listed twice");
      }
    }
    topics.push_back(std::move(topic));
  }
  if (topics.empty()) throw std::invalid_argument("no topics to record");
  return topics;
}

void resolveTopicTypes(Context& context, std::vector<RecordTopic>& topics, double timeout_s) {
  std::vector<std::string> wanted;
  for (const RecordTopic& topic : topics) {
    if (topic.type.empty()) wanted.push_back(Context::ddsTopicName(topic.name));
  }
  if (wanted.empty()) return;
  auto typeOf = [](const std::vector<DiscoveredWriter>& writers, const std::string& dds_name) {
    for (const DiscoveredWriter& writer : writers) {
      if (writer.topic == dds_name) return writer.type;
    }
    return std::string();
  };
  const std::vector<DiscoveredWriter> found = context.waitForWriters(
      [&](const std::vector<DiscoveredWriter>& writers) {
        for (const std::string& name : wanted) {
          if (typeOf(writers, name).empty()) return false;
        }
        return true;
      },
      timeout_s);
  std::string missing;
  for (RecordTopic& topic : topics) {
    if (!topic.type.empty()) continue;
    const std::string type = typeOf(found, Context::ddsTopicName(topic.name));
    if (type.empty()) {
      missing += (missing.empty() ? "" : ", ") + topic.name;
      continue;
    }
    topic.type = rosTypeName(type);
    if (!knownTypeTable().count(topic.type)) {
      throw std::invalid_argument("topic '" + topic.name + "' has type '" + topic.type +
                                  "', which storey cannot record; known: " + joinedKnownTypes());
    }
  }
  if (!missing.empty()) {
    throw std::invalid_argument("no publisher discovered within " + std::to_string(timeout_s) +
                                " s to tell the type of " + missing + ": give it as NAME:TYPE");
  }
}

TopicKind BagRecorder::recordKind(const RecordTopic& topic) {
  // tf_static as ros2 bag record takes it: its publishers (tf2's static broadcaster) send
  // each transform once, transient local, so only such a subscription gets one sent
  // before the recording started.
  if (isTfStaticTopic(topic.name)) return TopicKind::kGraph;
  const auto known = knownTypeTable().find(topic.type);
  return known == knownTypeTable().end() ? TopicKind::kSensor : known->second.kind;
}

namespace {
bag::BagWriterOptions storageOptions(const std::string& storage) {
  bag::BagWriterOptions options;
  options.storage = storage;
  return options;
}
}  // namespace

BagRecorder::BagRecorder(Context& context, const std::string& output_folder,
                         const std::vector<RecordTopic>& topics, const std::string& storage)
    : context_(context), bag_(output_folder, storageOptions(storage)) {
  for (const RecordTopic& topic : topics) {
    const auto known = knownTypeTable().find(topic.type);
    if (known == knownTypeTable().end()) {
      throw std::invalid_argument("topic '" + topic.name + "': type '" + topic.type +
                                  "' is not one storey can record");
    }
    const TopicKind kind = recordKind(topic);
    // Until a first message or close() knows the publishers' QoS, the subscription's
    // (which they match).
    const bool reliable = kind == TopicKind::kGraph;
    bag_.createTopic(
        {topic.name, topic.type, bag::kSerializationCdr, bag::qosProfileYaml(reliable, reliable)});
    topics_.push_back({topic, kind});
  }
  // Subscribed once topics_ is complete: store() reads it from DDS threads.
  for (const auto& [topic, kind] : topics_) {
    const std::string name = topic.name;
    subscriptions_.push_back(
        knownTypeTable()
            .at(topic.type)
            .subscribe(context, name, kind, [this, name](std::vector<std::uint8_t>&& bytes) {
              store(name, std::move(bytes));
            }));
  }
}

BagRecorder::~BagRecorder() {
  try {
    close();
  } catch (const std::exception& e) {
    common::logError(common::str("closing the recording: ", e.what()));
  }
}

void BagRecorder::store(const std::string& topic, std::vector<std::uint8_t>&& bytes) {
  bool first = false;
  {
    std::lock_guard<std::mutex> lock(counts_mutex_);
    first = counts_[topic]++ == 0;
  }
  // The publisher of a first message is discovered by now: its QoS goes into the topic
  // before the message (an MCAP channel keeps what its first message found).
  if (first)
    for (const auto& [recorded, kind] : topics_) {
      if (recorded.name != topic) continue;
      const std::vector<bag::OfferedQos> offered = offeredQos(recorded, kind);
      if (!offered.empty()) bag_.setOfferedQos(topic, bag::qosProfilesYaml(offered));
    }
  bag_.write(topic, nowNs(), bytes);
  ++count_;
}

std::map<std::string, std::uint64_t> BagRecorder::countsByTopic() const {
  std::lock_guard<std::mutex> lock(counts_mutex_);
  return counts_;
}

int BagRecorder::matchedPublishers() const {
  int matched = 0;
  for (const auto& s : subscriptions_) matched += s->matchedCount();
  return matched;
}

std::vector<bag::OfferedQos> BagRecorder::offeredQos(const RecordTopic& topic,
                                                     TopicKind kind) const {
  // The writers this recording's subscription could match: a reliable, transient-local
  // subscription matches only reliable, transient-local writers; a best-effort one any.
  const std::string dds_name = Context::ddsTopicName(topic.name);
  const bool need_strict = kind == TopicKind::kGraph;
  std::vector<bag::OfferedQos> offered;
  for (const DiscoveredWriter& writer : context_.discoveredWriters()) {
    if (writer.topic != dds_name || rosTypeName(writer.type) != topic.type) continue;
    if (need_strict && !(writer.reliable && writer.transient_local)) continue;
    offered.push_back({writer.reliable, writer.transient_local});
  }
  return offered;
}

void BagRecorder::close() {
  subscriptions_.clear();  // no callback runs after this
  if (!bag_.isOpen()) return;
  // What the publishers offered (as ros2 bag record stores it, one profile each), so a
  // replay publishes as they did; a topic nobody published keeps the subscription's.
  for (const auto& [topic, kind] : topics_) {
    const std::vector<bag::OfferedQos> offered = offeredQos(topic, kind);
    if (!offered.empty()) bag_.setOfferedQos(topic.name, bag::qosProfilesYaml(offered));
  }
  bag_.close();
}

}  // namespace storey::runtime
