#include "storey/bag/bag_reader.h"

#include <algorithm>
#include <filesystem>
#include <limits>

#include "storey/bag/bag_error.h"
#include "storey/bag/mcap_file.h"
#include "storey/bag/sqlite_db.h"
#include "storey/common/file_checks.h"

namespace storey::bag {

namespace fs = std::filesystem;

struct BagReader::Cursor {
  std::size_t file = 0;
  std::unique_ptr<detail::Statement> query;
  bool has_head = false;
  bool done = false;
  BagMessage head;
};

BagReader::BagReader(const std::string& path) : path_(path) {
  std::error_code ec;
  fs::path p(path);
  if (!fs::exists(p, ec)) throw BagError(path, "no such bag folder or file");
  if (fs::is_regular_file(p, ec) && p.filename() == "metadata.yaml") p = p.parent_path();
  if (fs::is_directory(p, ec)) {
    const fs::path yaml = p / "metadata.yaml";
    if (fs::exists(yaml, ec)) {
      metadata_ = readMetadataFile(yaml.string());
      if (metadata_->storage_identifier != kStorageSqlite3 &&
          metadata_->storage_identifier != kStorageMcap) {
        throw BagError(yaml.string(), "storage '" + metadata_->storage_identifier +
                                          "' is not supported (sqlite3 and mcap are)");
      }
      if (!metadata_->compression_format.empty()) {
        throw BagError(yaml.string(),
                       "compressed bags (" + metadata_->compression_format + ") are not supported");
      }
      for (const std::string& relative : metadata_->relative_file_paths) {
        fs::path file = p / relative;
        // Some older ROS 2 releases stored the path with the bag folder's name in front.
        if (!fs::exists(file, ec)) file = p / fs::path(relative).filename();
        if (!fs::exists(file, ec)) {
          throw BagError(yaml.string(), "lists " + relative + " which does not exist");
        }
        files_.push_back(file.string());
      }
    } else {
      for (const fs::directory_entry& entry : fs::directory_iterator(p, ec)) {
        const fs::path extension = entry.path().extension();
        if (extension == ".db3" || extension == ".mcap") files_.push_back(entry.path().string());
      }
      std::sort(files_.begin(), files_.end());
    }
    if (files_.empty())
      throw BagError(path, "not a bag: no metadata.yaml and no .db3 or .mcap file");
  } else {
    files_.push_back(p.string());
  }
  for (const std::string& file : files_) openFile(file);
  startCursors();
}

BagReader::~BagReader() {
  cursors_.clear();  // statements before their databases
}

void BagReader::addTopic(const TopicInfo& info, std::int64_t id, const std::string& file,
                         std::map<std::int64_t, std::size_t>& ids) {
  auto it = topic_index_.find(info.name);
  if (it == topic_index_.end()) {
    it = topic_index_.emplace(info.name, topics_.size()).first;
    topics_.push_back(info);
  } else if (topics_[it->second].type != info.type) {
    throw BagError(file, "topic " + info.name + " has type " + info.type + " here but " +
                             topics_[it->second].type + " in an earlier file");
  }
  ids[id] = it->second;
}

void BagReader::openMcap(const std::string& file) {
  auto mcap = std::make_unique<detail::McapFileReader>(file);
  if (storage_.empty()) storage_ = kStorageMcap;
  std::map<std::int64_t, std::size_t> ids;
  for (const auto& [id, topic] : mcap->channels()) addTopic(topic, id, file, ids);
  file_topics_.push_back(std::move(ids));
  dbs_.push_back(nullptr);
  mcaps_.push_back(std::move(mcap));
}

void BagReader::openFile(const std::string& file) {
  if (fs::path(file).extension() == ".mcap") {
    openMcap(file);
    return;
  }
  try {
    common::requireRegularFile(file, "bag database");  // sqlite would wait on a FIFO forever
  } catch (const std::runtime_error& e) {
    throw BagError(file, std::string(e.what()).substr(file.size() + 2));
  }
  if (detail::looksLikeMcap(file)) {  // an MCAP file by another name
    openMcap(file);
    return;
  }
  auto db = std::make_unique<detail::Database>(file, detail::Database::Mode::kReadOnly);
  if (storage_.empty()) storage_ = kStorageSqlite3;
  // The first query reads the header: a garbage file fails here, naming the file.
  bool has_tables = false;
  try {
    has_tables = db->hasTable("messages") && db->hasTable("topics");
  } catch (const BagError&) {
    throw BagError(file, "not a readable sqlite3 database: " + db->errorMessage());
  }
  if (!has_tables) {
    throw BagError(file, "not a rosbag2 database (no topics/messages tables)");
  }
  if (db->hasTable("schema")) {
    detail::Statement schema(*db, "SELECT schema_version, ros_distro FROM schema");
    if (schema.step() && dbs_.empty()) {
      schema_version_ = static_cast<int>(schema.columnInt(0));
      ros_distro_ = schema.columnText(1);
    }
  }
  const bool has_qos = db->hasColumn("topics", "offered_qos_profiles");
  detail::Statement query(*db, std::string("SELECT id, name, type, serialization_format, ") +
                                   (has_qos ? "offered_qos_profiles" : "''") +
                                   " FROM topics ORDER BY id");
  std::map<std::int64_t, std::size_t> ids;
  while (query.step()) {
    TopicInfo info;
    info.name = query.columnText(1);
    info.type = query.columnText(2);
    info.serialization_format = query.columnText(3);
    info.offered_qos_profiles = query.columnText(4);
    addTopic(info, query.columnInt(0), file, ids);
  }
  file_topics_.push_back(std::move(ids));
  dbs_.push_back(std::move(db));
  mcaps_.push_back(nullptr);
}

std::optional<std::size_t> BagReader::topicIndex(const std::string& name) const {
  const auto it = topic_index_.find(name);
  if (it == topic_index_.end()) return std::nullopt;
  return it->second;
}

void BagReader::setTopicFilter(const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    if (!topic_index_.count(name)) throw BagError(path_, "the bag has no topic " + name);
  }
  filter_ = names;
  startCursors();
}

void BagReader::rewind() { startCursors(); }

void BagReader::startCursors() {
  cursors_.clear();
  for (std::size_t f = 0; f < dbs_.size(); ++f) {
    // The file's ids of the topics asked for.
    std::vector<std::int64_t> wanted;
    for (const auto& [id, index] : file_topics_[f]) {
      const std::string& name = topics_[index].name;
      if (filter_.empty() || std::find(filter_.begin(), filter_.end(), name) != filter_.end())
        wanted.push_back(id);
    }
    auto cursor = std::make_unique<Cursor>();
    cursor->file = f;
    if (mcaps_[f]) {
      // An empty list is every channel: a filter matching none of this file's reads none.
      if (!filter_.empty() && wanted.empty()) cursor->done = true;
      mcaps_[f]->start(std::vector<std::uint16_t>(wanted.begin(), wanted.end()));
      cursors_.push_back(std::move(cursor));
      continue;
    }
    std::string where;
    if (!filter_.empty()) {
      std::string ids;
      for (const std::int64_t id : wanted) ids += (ids.empty() ? "" : ",") + std::to_string(id);
      where = " WHERE topic_id IN (" + ids + ")";
    }
    // id is the rowid, so the timestamp index serves this order without sorting.
    cursor->query = std::make_unique<detail::Statement>(
        *dbs_[f],
        "SELECT topic_id, timestamp, data FROM messages" + where + " ORDER BY timestamp, id");
    cursors_.push_back(std::move(cursor));
  }
}

bool BagReader::next(BagMessage& message) {
  Cursor* best = nullptr;
  for (auto& cursor : cursors_) {
    while (!cursor->has_head && !cursor->done && mcaps_[cursor->file]) {
      std::uint16_t channel = 0;
      bool more = false;
      try {
        more = mcaps_[cursor->file]->next(channel, cursor->head.stamp_ns, cursor->head.data);
      } catch (const BagError&) {
        cursor->done = true;
        throw;
      }
      if (!more) {
        cursor->done = true;
        break;
      }
      cursor->head.topic_index = file_topics_[cursor->file].at(channel);
      cursor->has_head = true;
    }
    while (!cursor->has_head && !cursor->done) {
      detail::Statement& q = *cursor->query;
      bool row = false;
      try {
        row = q.step();
      } catch (const BagError&) {
        cursor->done = true;
        throw;
      }
      if (!row) {
        cursor->done = true;
        break;
      }
      const auto& ids = file_topics_[cursor->file];
      const auto topic = ids.find(q.columnInt(0));
      if (topic == ids.end()) continue;  // a message of no declared topic: skipped
      cursor->head.topic_index = topic->second;
      cursor->head.stamp_ns = q.columnInt(1);
      const auto* bytes = static_cast<const std::uint8_t*>(q.columnBlob(2));
      const std::size_t size = q.columnBytes(2);
      cursor->head.data.assign(bytes, bytes + size);
      cursor->has_head = true;
    }
    if (cursor->has_head && (!best || cursor->head.stamp_ns < best->head.stamp_ns)) {
      best = cursor.get();
    }
  }
  if (!best) return false;
  message = std::move(best->head);
  best->head = BagMessage();
  best->has_head = false;
  return true;
}

const std::vector<TopicSummary>& BagReader::summary() {
  if (summary_) return *summary_;
  std::vector<TopicSummary> result(topics_.size());
  for (std::size_t i = 0; i < topics_.size(); ++i) result[i].topic = topics_[i];
  for (std::size_t f = 0; f < dbs_.size(); ++f) {
    if (mcaps_[f]) {
      for (const auto& [channel, count] : mcaps_[f]->counts()) {
        const auto topic = file_topics_[f].find(channel);
        if (topic == file_topics_[f].end()) continue;
        TopicSummary& s = result[topic->second];
        s.first_stamp_ns = s.message_count ? std::min(s.first_stamp_ns, count.first) : count.first;
        s.last_stamp_ns = s.message_count ? std::max(s.last_stamp_ns, count.last) : count.last;
        s.message_count += count.messages;
      }
      continue;
    }
    detail::Statement q(*dbs_[f],
                        "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages "
                        "GROUP BY topic_id");
    while (q.step()) {
      const auto topic = file_topics_[f].find(q.columnInt(0));
      if (topic == file_topics_[f].end()) continue;
      TopicSummary& s = result[topic->second];
      const auto count = static_cast<std::uint64_t>(q.columnInt(1));
      const std::int64_t first = q.columnInt(2);
      const std::int64_t last = q.columnInt(3);
      s.first_stamp_ns = s.message_count ? std::min(s.first_stamp_ns, first) : first;
      s.last_stamp_ns = s.message_count ? std::max(s.last_stamp_ns, last) : last;
      s.message_count += count;
    }
  }
  summary_ = std::move(result);
  return *summary_;
}

std::uint64_t BagReader::messageCount() {
  std::uint64_t total = 0;
  for (const TopicSummary& s : summary()) total += s.message_count;
  return total;
}

std::int64_t BagReader::startTimeNs() {
  std::int64_t start = std::numeric_limits<std::int64_t>::max();
  for (const TopicSummary& s : summary()) {
    if (s.message_count) start = std::min(start, s.first_stamp_ns);
  }
  return start == std::numeric_limits<std::int64_t>::max() ? 0 : start;
}

std::int64_t BagReader::endTimeNs() {
  std::int64_t end = std::numeric_limits<std::int64_t>::min();
  for (const TopicSummary& s : summary()) {
    if (s.message_count) end = std::max(end, s.last_stamp_ns);
  }
  return end == std::numeric_limits<std::int64_t>::min() ? 0 : end;
}

}  // namespace storey::bag
