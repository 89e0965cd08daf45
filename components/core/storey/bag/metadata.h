// rosbag2 bag metadata (the metadata.yaml beside the .db3 files), in the layout ROS 2
// Humble writes (metadata version 5). Reading accepts later versions too (Iron, Jazzy:
// extra keys are ignored, since this is foreign data, not storey configuration).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "storey/bag/bag_error.h"

namespace storey::bag {

inline constexpr const char* kSerializationCdr = "cdr";
inline constexpr const char* kStorageSqlite3 = "sqlite3";
inline constexpr const char* kStorageMcap = "mcap";

struct TopicInfo {
  std::string name;  // "/robot1/scan"
  std::string type;  // "sensor_msgs/msg/LaserScan"
  std::string serialization_format = kSerializationCdr;
  std::string offered_qos_profiles;  // rosbag2's YAML list of QoS profiles
};

// rosbag2's QoS profile text for a recorded topic (history/depth as ROS 2 records them).
std::string qosProfileYaml(bool reliable, bool transient_local);

// What a publisher offers, as far as rosbag2 stores it.
struct OfferedQos {
  bool reliable = false;
  bool transient_local = false;
};
// rosbag2's list for several publishers, one profile each in order ("" for none).
std::string qosProfilesYaml(const std::vector<OfferedQos>& profiles);

struct TopicWithCount {
  TopicInfo topic;
  std::uint64_t message_count = 0;
};

struct FileInfo {
  std::string path;  // relative to the bag folder
  std::int64_t starting_time_ns = 0;
  std::int64_t duration_ns = 0;
  std::uint64_t message_count = 0;
};

struct BagMetadata {
  int version = 5;
  std::string storage_identifier = kStorageSqlite3;
  std::int64_t duration_ns = 0;
  std::int64_t starting_time_ns = 0;
  std::uint64_t message_count = 0;
  std::vector<TopicWithCount> topics_with_message_count;
  std::string compression_format;
  std::string compression_mode;
  std::vector<std::string> relative_file_paths;
  std::vector<FileInfo> files;
};

// The metadata.yaml text.
std::string metadataToYaml(const BagMetadata& metadata);
// Parses metadata.yaml text; `file` names it in errors (BagError).
BagMetadata metadataFromYaml(const std::string& text, const std::string& file);
BagMetadata readMetadataFile(const std::string& path);
void writeMetadataFile(const std::string& path, const BagMetadata& metadata);

}  // namespace storey::bag
