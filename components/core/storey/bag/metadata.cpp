#include "storey/bag/metadata.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

#include "storey/bag/bag_error.h"
#include "storey/common/config.h"
#include "storey/common/file_checks.h"

namespace storey::bag {
namespace {

// ROS 2 writes "infinite" durations as INT64_MAX nanoseconds split into sec/nsec.
constexpr const char* kInfiniteDuration = "    sec: 9223372036\n    nsec: 854775807\n";

template <typename T>
T scalar(const YAML::Node& node, const std::string& key, const std::string& file) {
  const YAML::Node value = node[key];
  if (!value) {
    const int line = node.Mark().is_null() ? 0 : node.Mark().line + 1;
    throw BagError(file, "line " + std::to_string(line) + ": missing key '" + key + "'");
  }
  try {
    return value.as<T>();
  } catch (const YAML::Exception&) {
    throw BagError(file, "line " + std::to_string(value.Mark().line + 1) + ": key '" + key +
                             "' has a value of the wrong type");
  }
}

template <typename T>
T scalarOr(const YAML::Node& node, const std::string& key, const std::string& file,
           const T& fallback) {
  return node[key] ? scalar<T>(node, key, file) : fallback;
}

std::int64_t nested(const YAML::Node& node, const std::string& key, const std::string& inner,
                    const std::string& file) {
  const YAML::Node child = node[key];
  if (!child) {
    const int line = node.Mark().is_null() ? 0 : node.Mark().line + 1;
    throw BagError(file, "line " + std::to_string(line) + ": missing key '" + key + "'");
  }
  if (!child.IsMap()) {
    throw BagError(
        file, "line " + std::to_string(child.Mark().line + 1) + ": '" + key + "' is not a mapping");
  }
  return scalar<std::int64_t>(child, inner, file);
}

}  // namespace

std::string qosProfileYaml(bool reliable, bool transient_local) {
  std::ostringstream out;
  // history 3 / depth 0 is what ros2 bag record stores: unknown history, any depth.
  out << "- history: 3\n  depth: 0\n"
      << "  reliability: " << (reliable ? 1 : 2) << "\n"
      << "  durability: " << (transient_local ? 1 : 2) << "\n"
      << "  deadline:\n"
      << kInfiniteDuration << "  lifespan:\n"
      << kInfiniteDuration << "  liveliness: 1\n  liveliness_lease_duration:\n"
      << kInfiniteDuration << "  avoid_ros_namespace_conventions: false";
  return out.str();
}

std::string qosProfilesYaml(const std::vector<OfferedQos>& profiles) {
  std::string out;
  for (const OfferedQos& qos : profiles) {
    if (!out.empty()) out += "\n";
    out += qosProfileYaml(qos.reliable, qos.transient_local);
  }
  return out;
}

std::string metadataToYaml(const BagMetadata& m) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "rosbag2_bagfile_information" << YAML::Value
      << YAML::BeginMap;
  out << YAML::Key << "version" << YAML::Value << m.version;
  out << YAML::Key << "storage_identifier" << YAML::Value << m.storage_identifier;
  out << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds"
      << YAML::Value << m.duration_ns << YAML::EndMap;
  out << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key
      << "nanoseconds_since_epoch" << YAML::Value << m.starting_time_ns << YAML::EndMap;
  out << YAML::Key << "message_count" << YAML::Value << m.message_count;
  out << YAML::Key << "topics_with_message_count" << YAML::Value << YAML::BeginSeq;
  for (const TopicWithCount& t : m.topics_with_message_count) {
    out << YAML::BeginMap << YAML::Key << "topic_metadata" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << t.topic.name;
    out << YAML::Key << "type" << YAML::Value << t.topic.type;
    out << YAML::Key << "serialization_format" << YAML::Value << t.topic.serialization_format;
    out << YAML::Key << "offered_qos_profiles" << YAML::Value << YAML::DoubleQuoted
        << t.topic.offered_qos_profiles;
    out << YAML::EndMap;
    out << YAML::Key << "message_count" << YAML::Value << t.message_count << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "compression_format" << YAML::Value << YAML::DoubleQuoted
      << m.compression_format;
  out << YAML::Key << "compression_mode" << YAML::Value << YAML::DoubleQuoted << m.compression_mode;
  out << YAML::Key << "relative_file_paths" << YAML::Value << YAML::BeginSeq;
  for (const std::string& p : m.relative_file_paths) out << p;
  out << YAML::EndSeq;
  out << YAML::Key << "files" << YAML::Value << YAML::BeginSeq;
  for (const FileInfo& f : m.files) {
    out << YAML::BeginMap;
    out << YAML::Key << "path" << YAML::Value << f.path;
    out << YAML::Key << "starting_time" << YAML::Value << YAML::BeginMap << YAML::Key
        << "nanoseconds_since_epoch" << YAML::Value << f.starting_time_ns << YAML::EndMap;
    out << YAML::Key << "duration" << YAML::Value << YAML::BeginMap << YAML::Key << "nanoseconds"
        << YAML::Value << f.duration_ns << YAML::EndMap;
    out << YAML::Key << "message_count" << YAML::Value << f.message_count;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

BagMetadata metadataFromYaml(const std::string& text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw BagError(file, "line " + std::to_string(e.mark.line + 1) + ": malformed YAML: " + e.msg);
  }
  try {
    common::requireUniqueKeys(root, file);
  } catch (const common::ConfigError& e) {
    throw BagError(file, "line " + std::to_string(e.line()) + ": " + e.key() + ": " + e.problem());
  }
  const YAML::Node info = root.IsMap() ? root["rosbag2_bagfile_information"] : YAML::Node();
  if (!info || !info.IsMap()) {
    throw BagError(file, "not a rosbag2 metadata file (no rosbag2_bagfile_information mapping)");
  }
  BagMetadata m;
  m.version = scalar<int>(info, "version", file);
  m.storage_identifier = scalar<std::string>(info, "storage_identifier", file);
  m.duration_ns = nested(info, "duration", "nanoseconds", file);
  m.starting_time_ns = nested(info, "starting_time", "nanoseconds_since_epoch", file);
  m.message_count = scalar<std::uint64_t>(info, "message_count", file);
  m.compression_format = scalarOr<std::string>(info, "compression_format", file, "");
  m.compression_mode = scalarOr<std::string>(info, "compression_mode", file, "");
  if (const YAML::Node topics = info["topics_with_message_count"]; topics && topics.IsSequence()) {
    for (const YAML::Node& entry : topics) {
      const YAML::Node meta = entry["topic_metadata"];
      if (!meta || !meta.IsMap()) throw BagError(file, "a topic has no topic_metadata mapping");
      TopicWithCount t;
      t.topic.name = scalar<std::string>(meta, "name", file);
      t.topic.type = scalar<std::string>(meta, "type", file);
      t.topic.serialization_format =
          scalarOr<std::string>(meta, "serialization_format", file, kSerializationCdr);
      // Jazzy writes the QoS profiles as a YAML list; Humble as a string holding YAML.
      if (const YAML::Node qos = meta["offered_qos_profiles"]; qos && qos.IsScalar()) {
        t.topic.offered_qos_profiles = qos.as<std::string>();
      } else if (qos && !qos.IsNull()) {
        YAML::Emitter emit;
        emit << qos;
        t.topic.offered_qos_profiles = emit.c_str();
      }
      t.message_count = scalar<std::uint64_t>(entry, "message_count", file);
      m.topics_with_message_count.push_back(std::move(t));
    }
  }
  if (const YAML::Node paths = info["relative_file_paths"]; paths && paths.IsSequence()) {
    for (const YAML::Node& p : paths) m.relative_file_paths.push_back(p.as<std::string>());
  }
  if (const YAML::Node files = info["files"]; files && files.IsSequence()) {
    for (const YAML::Node& f : files) {
      FileInfo fi;
      fi.path = scalar<std::string>(f, "path", file);
      fi.starting_time_ns = nested(f, "starting_time", "nanoseconds_since_epoch", file);
      fi.duration_ns = nested(f, "duration", "nanoseconds", file);
      fi.message_count = scalar<std::uint64_t>(f, "message_count", file);
      m.files.push_back(std::move(fi));
    }
  }
  return m;
}

BagMetadata readMetadataFile(const std::string& path) {
  try {
    common::requireRegularFile(path, "bag metadata file", common::kMaxYamlFileBytes);
  } catch (const std::runtime_error& e) {
    throw BagError(path, std::string(e.what()).substr(path.size() + 2));
  }
  std::ifstream in(path);
  if (!in) throw BagError(path, "cannot open metadata file");
  std::stringstream text;
  text << in.rdbuf();
  return metadataFromYaml(text.str(), path);
}

void writeMetadataFile(const std::string& path, const BagMetadata& metadata) {
  std::ofstream out(path);
  out << metadataToYaml(metadata);
  out.close();
  if (!out) throw BagError(path, "cannot write metadata file");
}

}  // namespace storey::bag
