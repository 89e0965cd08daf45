// Writes a rosbag2 bag: a folder holding metadata.yaml and <name>_0.db3 (sqlite3 storage,
// ROS 2 Humble layout, schema 3; inserts batched in transactions) or <name>_0.mcap (mcap
// storage, mcap_file.h). Messages are opaque serialized bytes (CDR with its 4-byte
// encapsulation header for ROS 2 types). Thread-safe: record callbacks may write from
// several threads.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "storey/bag/bag_error.h"
#include "storey/bag/metadata.h"

namespace storey::bag {

namespace detail {
class Database;
class Statement;
class McapFileWriter;
}  // namespace detail

struct BagWriterOptions {
  std::size_t batch_size = 2000;          // sqlite3: messages per transaction
  std::string ros_distro = "humble";      // sqlite3: stored in the schema table
  std::string storage = kStorageSqlite3;  // kStorageSqlite3 or kStorageMcap
};

class BagWriter {
 public:
  BagWriter();
  // Opens at once (see open()).
  explicit BagWriter(const std::string& folder, BagWriterOptions options = {});
  ~BagWriter();  // closes; errors are logged, never thrown from here
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  // Creates `folder` (which must not exist, or be an empty folder) and its storage file.
  void open(const std::string& folder, BagWriterOptions options = {});
  // Declares a topic. Declaring the same name again with the same type is a no-op; with a
  // different type it is an error.
  void createTopic(const TopicInfo& topic);
  bool hasTopic(const std::string& name) const;
  // Replaces a declared topic's offered QoS profiles (in the database and the metadata):
  // a recorder learns what the publishers offer only once it has discovered them. MCAP
  // keeps a topic's channel record as its first message found it (MCAP requires the
  // records of one channel to be identical); metadata.yaml has the last profiles set.
  void setOfferedQos(const std::string& name, const std::string& offered_qos_profiles);
  // Appends one message on a declared topic; stamps need not be ordered.
  void write(const std::string& topic, std::int64_t stamp_ns, const std::uint8_t* data,
             std::size_t size);
  void write(const std::string& topic, std::int64_t stamp_ns,
             const std::vector<std::uint8_t>& data) {
    write(topic, stamp_ns, data.data(), data.size());
  }
  // Commits, closes the storage file and writes metadata.yaml. Idempotent.
  void close();

  bool isOpen() const { return db_ != nullptr || mcap_ != nullptr; }
  const std::string& folder() const { return folder_; }
  std::string databasePath() const;  // the storage file (.db3 or .mcap)
  std::uint64_t messageCount() const;

 private:
  struct Topic {
    std::int64_t id = 0;  // sqlite topic id or MCAP channel id
    TopicInfo info;
    std::uint64_t count = 0;
  };
  void commitLocked();
  void closeLocked();

  mutable std::mutex mutex_;
  BagWriterOptions options_;
  std::string folder_;
  std::string db_name_;
  std::unique_ptr<detail::Database> db_;
  std::unique_ptr<detail::Statement> insert_;
  std::unique_ptr<detail::McapFileWriter> mcap_;
  std::map<std::string, Topic> topics_;
  std::vector<std::string> topic_order_;
  std::size_t pending_ = 0;
  std::uint64_t count_ = 0;
  std::int64_t min_stamp_ = 0;
  std::int64_t max_stamp_ = 0;
};

}  // namespace storey::bag
