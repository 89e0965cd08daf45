// Reads rosbag2 bags with sqlite3 storage (ROS 2 Humble's schema 3, Jazzy's schema 4: an
// extra topics column and table, ignored; older layouts without the schema table) or mcap
// storage (mcap_file.h). Accepts a bag folder (metadata.yaml lists the files; without it
// every *.db3 and *.mcap in the folder is read) or a single .db3 or .mcap file. Messages
// stream in time order (merged across split files); no file is loaded whole.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "storey/bag/bag_error.h"
#include "storey/bag/metadata.h"

namespace storey::bag {

namespace detail {
class Database;
class Statement;
class McapFileReader;
}  // namespace detail

struct BagMessage {
  std::size_t topic_index = 0;  // into BagReader::topics()
  std::int64_t stamp_ns = 0;
  std::vector<std::uint8_t> data;
};

struct TopicSummary {
  TopicInfo topic;
  std::uint64_t message_count = 0;
  std::int64_t first_stamp_ns = 0;  // meaningful when message_count > 0
  std::int64_t last_stamp_ns = 0;
};

class BagReader {
 public:
  // Throws BagError naming the file: missing path, no .db3 or .mcap, not an sqlite
  // database or MCAP file, not a rosbag2 database, unsupported storage or compression.
  explicit BagReader(const std::string& path);
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  const std::string& path() const { return path_; }
  const std::vector<std::string>& files() const { return files_; }
  const std::vector<TopicInfo>& topics() const { return topics_; }
  std::optional<std::size_t> topicIndex(const std::string& name) const;
  // kStorageSqlite3 or kStorageMcap, of the first file (split bags have one storage).
  const std::string& storage() const { return storage_; }
  int schemaVersion() const { return schema_version_; }  // sqlite3; 0: no schema table (pre-Humble)
  const std::string& rosDistro() const { return ros_distro_; }
  const std::optional<BagMetadata>& metadata() const { return metadata_; }

  // Counts and time span from the databases (one aggregate query per file, on first use).
  const std::vector<TopicSummary>& summary();
  std::uint64_t messageCount();
  std::int64_t startTimeNs();  // 0 for an empty bag
  std::int64_t endTimeNs();

  // Only these topics from now on (empty: all); unknown names are an error. Rewinds.
  void setTopicFilter(const std::vector<std::string>& names);
  // The next message in time order (ties: file, then insertion order); false at the end.
  // A corrupt or truncated database throws BagError naming it; messages returned before
  // stay valid, and the next call continues with the remaining files.
  bool next(BagMessage& message);
  void rewind();

 private:
  struct Cursor;
  void openFile(const std::string& file);
  void openMcap(const std::string& file);
  void addTopic(const TopicInfo& info, std::int64_t id, const std::string& file,
                std::map<std::int64_t, std::size_t>& ids);
  void startCursors();

  std::string path_;
  std::vector<std::string> files_;
  std::optional<BagMetadata> metadata_;
  std::string storage_;
  int schema_version_ = 0;
  std::string ros_distro_;
  std::vector<TopicInfo> topics_;
  std::map<std::string, std::size_t> topic_index_;
  // Per file, one of the two: an sqlite database or an MCAP file.
  std::vector<std::unique_ptr<detail::Database>> dbs_;
  std::vector<std::unique_ptr<detail::McapFileReader>> mcaps_;
  std::vector<std::map<std::int64_t, std::size_t>> file_topics_;  // per file: id -> index
  std::vector<std::string> filter_;
  std::vector<std::unique_ptr<Cursor>> cursors_;
  std::optional<std::vector<TopicSummary>> summary_;
};

}  // namespace storey::bag
