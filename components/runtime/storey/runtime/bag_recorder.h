// Records DDS topics into a rosbag2 bag: one typed subscription per topic for the message
// types storey knows (ROS 2 standard types and storey_msgs); each sample is serialized back
// to CDR and stored with its receive time, as `ros2 bag record` does.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "storey/bag/bag_writer.h"
#include "storey/runtime/context.h"
#include "storey/runtime/subscription.h"

namespace storey::runtime {

struct RecordTopic {
  std::string name;  // ROS 2 name, "/robot1/scan"
  std::string type;  // "sensor_msgs/msg/LaserScan"; "" to infer it from the name
};

// Parses "a,b:pkg/msg/T" into topics; types not given are inferred from the last name
// token (scan, odom, pressure, imu, tf, tf_static), else left empty for
// resolveTopicTypes. Throws std::invalid_argument naming the entry for a type storey
// cannot record, an empty name or a topic listed twice.
std::vector<RecordTopic> parseRecordTopics(const std::string& list);

// Fills the empty types from DDS discovery: waits up to timeout_s for a writer on each
// such topic and takes its type (as `ros2 bag record` does). Throws std::invalid_argument
// naming the topics still unresolved, or a discovered type storey cannot record.
void resolveTopicTypes(Context& context, std::vector<RecordTopic>& topics, double timeout_s);

class BagRecorder {
 public:
  // Opens the bag (a new folder; storage bag::kStorageSqlite3 or kStorageMcap) and
  // subscribes to every topic.
  BagRecorder(Context& context, const std::string& output_folder,
              const std::vector<RecordTopic>& topics,
              const std::string& storage = bag::kStorageSqlite3);
  ~BagRecorder();  // unsubscribes, then closes the bag
  BagRecorder(const BagRecorder&) = delete;
  BagRecorder& operator=(const BagRecorder&) = delete;

  static std::vector<std::string> knownTypes();
  static std::string inferType(const std::string& topic_name);  // "" when not inferable
  // The QoS a topic is recorded with: tf_static (any namespace) reliable and transient
  // local, to get what was sent before the recording started, as ros2 bag record does;
  // else by type (sensor types best effort, storey's graph types transient local).
  static TopicKind recordKind(const RecordTopic& topic);

  std::uint64_t messageCount() const { return count_; }
  std::map<std::string, std::uint64_t> countsByTopic() const;
  int matchedPublishers() const;  // summed over the topics
  // Unsubscribes and writes metadata.yaml, with each topic's QoS as its publishers offered
  // it. Idempotent.
  void close();

 private:
  void store(const std::string& topic, std::vector<std::uint8_t>&& bytes);
  std::vector<bag::OfferedQos> offeredQos(const RecordTopic& topic, TopicKind kind) const;

  Context& context_;
  bag::BagWriter bag_;
  std::vector<std::pair<RecordTopic, TopicKind>> topics_;
  std::vector<std::unique_ptr<SubscriptionBase>> subscriptions_;
  std::atomic<std::uint64_t> count_{0};
  mutable std::mutex counts_mutex_;
  std::map<std::string, std::uint64_t> counts_;
};

}  // namespace storey::runtime
