#include <zstd.h>

#include <algorithm>
#include <utility>

#include "storey/bag/bag_error.h"
#include "storey/bag/mcap_file.h"
#include "storey/bag/mcap_records.h"

namespace storey::bag::detail {

using namespace mcap;  // NOLINT(google-build-using-namespace): this file's own format

namespace {

constexpr std::size_t kChunkTarget = 1u << 20;  // uncompressed bytes per written chunk

// Record content being built.
struct Bytes {
  std::vector<std::uint8_t> b;
  Bytes& uint(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  Bytes& text(const std::string& s) {
    uint(s.size(), 4);
    b.insert(b.end(), s.begin(), s.end());
    return *this;
  }
  Bytes& raw(const std::uint8_t* p, std::size_t n) {
    b.insert(b.end(), p, p + n);
    return *this;
  }
};

std::vector<std::uint8_t> record(Op op, const Bytes& content) {
  Bytes r;
  r.uint(op, 1).uint(content.b.size(), 8).raw(content.b.data(), content.b.size());
  return std::move(r.b);
}

}  // namespace

McapFileWriter::McapFileWriter(const std::string& file) : file_(file) {
  out_.open(file, std::ios::binary | std::ios::trunc);
  if (!out_) throw BagError(file, "cannot create the MCAP file");
  put(std::vector<std::uint8_t>(kMagic, kMagic + 8));
  put(record(kHeader, Bytes().text("ros2").text("storey")));
}

McapFileWriter::~McapFileWriter() = default;

void McapFileWriter::put(const std::vector<std::uint8_t>& bytes) {
  out_.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  if (!out_) throw BagError(file_, "write failed at byte " + std::to_string(offset_));
  offset_ += bytes.size();
}

std::uint16_t McapFileWriter::addTopic(const TopicInfo& topic) {
  if (channels_.size() >= 0xffff) throw BagError(file_, "more than 65535 topics");
  Channel c;
  c.topic = topic;
  auto schema = schema_ids_.find(topic.type);
  if (schema == schema_ids_.end())
    schema =
        schema_ids_.emplace(topic.type, static_cast<std::uint16_t>(schema_ids_.size() + 1)).first;
  c.schema = schema->second;
  channels_.push_back(c);
  return static_cast<std::uint16_t>(channels_.size());
}

void McapFileWriter::setOfferedQos(std::uint16_t channel, const std::string& offered_qos_profiles) {
  Channel& c = channels_.at(channel - 1u);
  if (!c.written) c.topic.offered_qos_profiles = offered_qos_profiles;
}

namespace {

Bytes schemaRecord(std::uint16_t id, const std::string& type) {
  const std::string idl = ros2IdlSchema(type);
  Bytes b;
  b.uint(id, 2).text(type).text(idl.empty() ? "" : "ros2idl").text(idl);
  return b;
}

Bytes channelRecord(std::uint16_t id, std::uint16_t schema, const TopicInfo& topic) {
  Bytes metadata;
  metadata.text("offered_qos_profiles").text(topic.offered_qos_profiles);
  Bytes b;
  b.uint(id, 2).uint(schema, 2).text(topic.name).text(topic.serialization_format);
  b.uint(metadata.b.size(), 4).raw(metadata.b.data(), metadata.b.size());
  return b;
}

}  // namespace

void McapFileWriter::write(std::uint16_t channel, std::int64_t stamp, const std::uint8_t* data,
                           std::size_t size) {
  Channel& c = channels_.at(channel - 1u);
  if (!c.written) {
    bool schema_written = false;
    for (const Channel& other : channels_)
      schema_written |= other.written && other.schema == c.schema;
    std::vector<std::uint8_t> records;
    if (!schema_written) records = record(kSchema, schemaRecord(c.schema, c.topic.type));
    const auto ch = record(kChannel, channelRecord(channel, c.schema, c.topic));
    records.insert(records.end(), ch.begin(), ch.end());
    chunk_.insert(chunk_.end(), records.begin(), records.end());
    c.written = true;
  }
  const auto time = static_cast<std::uint64_t>(stamp);
  chunk_index_[channel].emplace_back(time, chunk_.size());
  Bytes m;
  m.uint(kMessage, 1).uint(kMessageHeader + size, 8);
  m.uint(channel, 2).uint(c.sequence++, 4).uint(time, 8).uint(time, 8).raw(data, size);
  chunk_.insert(chunk_.end(), m.b.begin(), m.b.end());
  if (messages_in_chunk_++ == 0) {
    chunk_start_ = chunk_end_ = stamp;
  } else {
    chunk_start_ = std::min(chunk_start_, stamp);
    chunk_end_ = std::max(chunk_end_, stamp);
  }
  if (messages_++ == 0) {
    first_ = last_ = stamp;
  } else {
    first_ = std::min(first_, stamp);
    last_ = std::max(last_, stamp);
  }
  ++c.count;
  if (chunk_.size() >= kChunkTarget) flushChunk();
}

void McapFileWriter::flushChunk() {
  if (chunk_.empty()) return;
  std::vector<std::uint8_t> compressed(ZSTD_compressBound(chunk_.size()));
  const std::size_t n =
      ZSTD_compress(compressed.data(), compressed.size(), chunk_.data(), chunk_.size(), 1);
  if (ZSTD_isError(n)) throw BagError(file_, std::string("zstd: ") + ZSTD_getErrorName(n));
  compressed.resize(n);
  const std::uint64_t chunk_offset = offset_;
  Bytes chunk;
  chunk.uint(static_cast<std::uint64_t>(chunk_start_), 8)
      .uint(static_cast<std::uint64_t>(chunk_end_), 8);
  chunk.uint(chunk_.size(), 8).uint(crc32Of(chunk_.data(), chunk_.size()), 4).text("zstd");
  chunk.uint(compressed.size(), 8).raw(compressed.data(), compressed.size());
  put(record(kChunk, chunk));
  const std::uint64_t chunk_length = offset_ - chunk_offset;
  // A message index per channel after the chunk.
  Bytes offsets;
  const std::uint64_t indexes_start = offset_;
  for (const auto& [channel, index] : chunk_index_) {
    offsets.uint(channel, 2).uint(offset_, 8);
    Bytes entries;
    for (const auto& [time, at] : index) entries.uint(time, 8).uint(at, 8);
    Bytes m;
    m.uint(channel, 2).uint(entries.b.size(), 4).raw(entries.b.data(), entries.b.size());
    put(record(kMessageIndex, m));
  }
  Bytes ci;
  ci.uint(static_cast<std::uint64_t>(chunk_start_), 8)
      .uint(static_cast<std::uint64_t>(chunk_end_), 8);
  ci.uint(chunk_offset, 8).uint(chunk_length, 8);
  ci.uint(offsets.b.size(), 4).raw(offsets.b.data(), offsets.b.size());
  ci.uint(offset_ - indexes_start, 8)
      .text("zstd")
      .uint(compressed.size(), 8)
      .uint(chunk_.size(), 8);
  const auto index_record = record(kChunkIndex, ci);
  chunk_indexes_.insert(chunk_indexes_.end(), index_record.begin(), index_record.end());
  ++chunk_count_;
  chunk_.clear();
  chunk_index_.clear();
  messages_in_chunk_ = 0;
}

void McapFileWriter::close() {
  if (closed_) return;
  closed_ = true;
  flushChunk();
  // Topics without messages: their schema and channel in the data section all the same.
  std::vector<bool> schema_written(schema_ids_.size() + 1, false);
  for (const Channel& c : channels_)
    schema_written[c.schema] = schema_written[c.schema] || c.written;
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    Channel& c = channels_[i];
    if (c.written) continue;
    if (!schema_written[c.schema]) put(record(kSchema, schemaRecord(c.schema, c.topic.type)));
    schema_written[c.schema] = true;
    put(record(kChannel, channelRecord(static_cast<std::uint16_t>(i + 1), c.schema, c.topic)));
    c.written = true;
  }
  put(record(kDataEnd, Bytes().uint(0, 4)));
  // The summary, grouped by opcode, each group's place in a summary offset record.
  const std::uint64_t summary_start = offset_;
  Bytes offsets;
  auto group = [&](Op op, const std::vector<std::uint8_t>& records) {
    if (records.empty()) return;
    offsets.uint(op, 1).uint(offset_, 8).uint(records.size(), 8);
    put(records);
  };
  std::vector<std::uint8_t> schemas, channels, statistics;
  for (const auto& [type, id] : schema_ids_) {
    const auto r = record(kSchema, schemaRecord(id, type));
    schemas.insert(schemas.end(), r.begin(), r.end());
  }
  Bytes counts;
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    const auto id = static_cast<std::uint16_t>(i + 1);
    const auto r = record(kChannel, channelRecord(id, channels_[i].schema, channels_[i].topic));
    channels.insert(channels.end(), r.begin(), r.end());
    counts.uint(id, 2).uint(channels_[i].count, 8);
  }
  Bytes stats;
  stats.uint(messages_, 8)
      .uint(schema_ids_.size(), 2)
      .uint(channels_.size(), 4)
      .uint(0, 4)
      .uint(0, 4);
  stats.uint(chunk_count_, 4)
      .uint(static_cast<std::uint64_t>(first_), 8)
      .uint(static_cast<std::uint64_t>(last_), 8);
  stats.uint(counts.b.size(), 4).raw(counts.b.data(), counts.b.size());
  statistics = record(kStatistics, stats);
  group(kSchema, schemas);
  group(kChannel, channels);
  group(kStatistics, statistics);
  group(kChunkIndex, chunk_indexes_);
  const std::uint64_t summary_offset_start = offset_;
  for (std::size_t i = 0; i < offsets.b.size(); i += 17) {
    Bytes so;
    so.raw(offsets.b.data() + i, 17);
    put(record(kSummaryOffset, so));
  }
  put(record(kFooter, Bytes().uint(summary_start, 8).uint(summary_offset_start, 8).uint(0, 4)));
  put(std::vector<std::uint8_t>(kMagic, kMagic + 8));
  out_.close();
  if (!out_) throw BagError(file_, "closing failed");
}

}  // namespace storey::bag::detail
