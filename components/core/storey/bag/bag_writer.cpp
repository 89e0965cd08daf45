#include "storey/bag/bag_writer.h"

#include <algorithm>
#include <filesystem>

#include "storey/bag/bag_error.h"
#include "storey/bag/mcap_file.h"
#include "storey/bag/sqlite_db.h"
#include "storey/common/log.h"

namespace storey::bag {

namespace fs = std::filesystem;

BagWriter::BagWriter() = default;

BagWriter::BagWriter(const std::string& folder, BagWriterOptions options) {
  open(folder, std::move(options));
}

BagWriter::~BagWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    common::logError(common::str("closing bag: ", e.what()));
  }
}

void BagWriter::open(const std::string& folder, BagWriterOptions options) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (isOpen()) throw BagError(folder_, "bag is already open");
  if (options.batch_size == 0) throw BagError(folder, "batch_size must be positive");
  if (options.storage != kStorageSqlite3 && options.storage != kStorageMcap)
    throw BagError(folder, "storage '" + options.storage + "' is not one of sqlite3, mcap");
  std::error_code ec;
  const fs::path dir(folder);
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec)) {
      throw BagError(folder, "output exists and is not an empty folder");
    }
  } else if (!fs::create_directories(dir, ec) || ec) {
    throw BagError(folder, "cannot create folder: " + ec.message());
  }
  std::string name = dir.filename().string();
  if (name.empty()) name = dir.parent_path().filename().string();
  if (name.empty()) name = "bag";
  options_ = std::move(options);
  folder_ = folder;
  topics_.clear();
  topic_order_.clear();
  pending_ = 0;
  count_ = 0;
  if (options_.storage == kStorageMcap) {
    db_name_ = name + "_0.mcap";
    mcap_ = std::make_unique<detail::McapFileWriter>((dir / db_name_).string());
    return;
  }
  db_name_ = name + "_0.db3";

  db_ = std::make_unique<detail::Database>((dir / db_name_).string(),
                                           detail::Database::Mode::kCreate);
  // rosbag2's default "speed" preset: no fsync per commit, rollback journal in memory.
  db_->exec("PRAGMA journal_mode=MEMORY; PRAGMA synchronous=OFF; PRAGMA page_size=4096;");
  db_->exec(
      "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
      "CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, "
      "metadata TEXT NOT NULL);"
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
      "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
      "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "CREATE INDEX timestamp_idx ON messages (timestamp ASC);");
  detail::Statement schema(*db_, "INSERT INTO schema(schema_version, ros_distro) VALUES(3, ?)");
  schema.bind(1, options_.ros_distro);
  schema.step();
  insert_ = std::make_unique<detail::Statement>(
      *db_, "INSERT INTO messages(topic_id, timestamp, data) VALUES(?, ?, ?)");
}

std::string BagWriter::databasePath() const { return (fs::path(folder_) / db_name_).string(); }

void BagWriter::createTopic(const TopicInfo& topic) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!isOpen()) throw BagError(folder_, "createTopic on a closed bag");
  if (topic.name.empty() || topic.type.empty()) {
    throw BagError(folder_, "a topic needs a name and a type");
  }
  if (const auto it = topics_.find(topic.name); it != topics_.end()) {
    if (it->second.info.type != topic.type) {
      throw BagError(folder_, "topic " + topic.name + " already has type " + it->second.info.type +
                                  ", not " + topic.type);
    }
    return;
  }
  Topic entry;
  entry.info = topic;
  if (mcap_) {
    entry.id = mcap_->addTopic(topic);
    topics_.emplace(topic.name, std::move(entry));
    topic_order_.push_back(topic.name);
    return;
  }
  detail::Statement insert(*db_,
                           "INSERT INTO topics(name, type, serialization_format, "
                           "offered_qos_profiles) VALUES(?, ?, ?, ?)");
  insert.bind(1, topic.name);
  insert.bind(2, topic.type);
  insert.bind(3, topic.serialization_format);
  insert.bind(4, topic.offered_qos_profiles);
  insert.step();
  detail::Statement id(*db_, "SELECT last_insert_rowid()");
  id.step();
  entry.id = id.columnInt(0);
  topics_.emplace(topic.name, std::move(entry));
  topic_order_.push_back(topic.name);
}

bool BagWriter::hasTopic(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return topics_.count(name) > 0;
}

void BagWriter::setOfferedQos(const std::string& name, const std::string& offered_qos_profiles) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!isOpen()) throw BagError(folder_, "setOfferedQos on a closed bag");
  const auto it = topics_.find(name);
  if (it == topics_.end()) throw BagError(folder_, "setOfferedQos on undeclared topic " + name);
  it->second.info.offered_qos_profiles = offered_qos_profiles;
  if (mcap_) {
    mcap_->setOfferedQos(static_cast<std::uint16_t>(it->second.id), offered_qos_profiles);
    return;
  }
  detail::Statement update(*db_, "UPDATE topics SET offered_qos_profiles = ? WHERE id = ?");
  update.bind(1, offered_qos_profiles);
  update.bind(2, it->second.id);
  update.step();
}

void BagWriter::write(const std::string& topic, std::int64_t stamp_ns, const std::uint8_t* data,
                      std::size_t size) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!isOpen()) throw BagError(folder_, "write on a closed bag");
  const auto it = topics_.find(topic);
  if (it == topics_.end()) throw BagError(folder_, "write on undeclared topic " + topic);
  if (mcap_) {
    mcap_->write(static_cast<std::uint16_t>(it->second.id), stamp_ns, data, size);
  } else {
    if (pending_ == 0) db_->exec("BEGIN TRANSACTION");
    insert_->bind(1, it->second.id);
    insert_->bind(2, stamp_ns);
    insert_->bindBlob(3, data, size);
    insert_->step();
    insert_->reset();
  }
  ++it->second.count;
  if (count_ == 0) {
    min_stamp_ = max_stamp_ = stamp_ns;
  } else {
    min_stamp_ = std::min(min_stamp_, stamp_ns);
    max_stamp_ = std::max(max_stamp_, stamp_ns);
  }
  ++count_;
  if (db_ && ++pending_ >= options_.batch_size) commitLocked();
}

void BagWriter::commitLocked() {
  if (pending_ == 0) return;
  db_->exec("COMMIT");
  pending_ = 0;
}

std::uint64_t BagWriter::messageCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

void BagWriter::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closeLocked();
}

void BagWriter::closeLocked() {
  if (!isOpen()) return;
  BagMetadata m;
  m.storage_identifier = options_.storage;
  m.starting_time_ns = count_ ? min_stamp_ : 0;
  m.duration_ns = count_ ? max_stamp_ - min_stamp_ : 0;
  m.message_count = count_;
  for (const std::string& name : topic_order_) {
    const Topic& t = topics_.at(name);
    m.topics_with_message_count.push_back({t.info, t.count});
  }
  m.relative_file_paths = {db_name_};
  m.files = {{db_name_, m.starting_time_ns, m.duration_ns, count_}};
  if (mcap_) {
    // Released even when closing fails, so the object is reusable.
    std::unique_ptr<detail::McapFileWriter> mcap = std::move(mcap_);
    mcap->close();
    writeMetadataFile((fs::path(folder_) / "metadata.yaml").string(), m);
    return;
  }
  // Release the database even when the last commit fails, so the object is reusable.
  std::unique_ptr<detail::Statement> insert = std::move(insert_);
  std::unique_ptr<detail::Database> db = std::move(db_);
  if (pending_ > 0) {
    pending_ = 0;
    db->exec("COMMIT");
  }
  insert.reset();
  db.reset();
  writeMetadataFile((fs::path(folder_) / "metadata.yaml").string(), m);
}

}  // namespace storey::bag
