// MCAP files as rosbag2 stores them (the `mcap` storage, ROS 2's default since Iron): the
// container of https://mcap.dev (magic, little-endian records), profile `ros2`, one
// channel per topic with the schema name as the ROS type, `cdr` messages and the
// offered QoS in the channel's `offered_qos_profiles`. Internal to BagReader/BagWriter.
#pragma once

#include <cstdint>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "storey/bag/metadata.h"

namespace storey::bag::detail {

// True when `file` starts with MCAP's magic bytes.
bool looksLikeMcap(const std::string& file);

// A chunk's uncompressed records are at most this large (rosbag2 writes about 1 MiB).
inline constexpr std::uint64_t kMaxMcapChunkBytes = 256ull << 20;

// Reads one .mcap file: a linear pass over its data section on opening (chunks
// decompressed: none, zstd, lz4 frames; CRCs checked where written) indexes every message
// by log time; messages are then read one at a time in time order (ties: file order),
// one decompressed chunk kept. A truncated file (a recording cut short) gives its complete
// messages, then the BagError naming where it was cut.
class McapFileReader {
 public:
  struct Count {
    std::uint64_t messages = 0;
    std::int64_t first = 0, last = 0;
  };

  // Throws BagError naming `file`: not an MCAP file, a record that does not parse, a
  // chunk whose compression is unknown or whose CRC does not match.
  explicit McapFileReader(const std::string& file);

  // Channel id -> topic (name, schema name as type, message encoding, offered QoS).
  const std::map<std::uint16_t, TopicInfo>& channels() const { return channels_; }
  std::map<std::uint16_t, Count> counts() const;
  // Reads from the first message again, only `channels` (all when empty).
  void start(const std::vector<std::uint16_t>& channels);
  // The next message; false at the end, or throws the truncation's BagError once after the
  // last complete message.
  bool next(std::uint16_t& channel, std::int64_t& stamp, std::vector<std::uint8_t>& data);

 private:
  struct Entry {
    std::int64_t stamp;
    std::uint32_t chunk;  // kDirect: a message record outside chunks
    std::uint16_t channel;
    std::uint64_t offset;  // of the message's data: in the file, or in the chunk's records
    std::uint64_t size;
  };
  struct Chunk {
    std::uint64_t offset;  // of the compressed records in the file
    std::uint64_t compressed, uncompressed;
    std::uint32_t crc;
    std::string compression;
  };
  static constexpr std::uint32_t kDirect = 0xffffffffu;

  void scan();
  void readRecords(const std::vector<std::uint8_t>& records, std::uint32_t chunk,
                   std::uint64_t file_at);
  // A chunk's records: read from the file, or unpacked from its compressed bytes.
  std::vector<std::uint8_t> chunkRecords(std::uint32_t chunk);
  std::vector<std::uint8_t> unpackChunk(const Chunk& chunk, const std::uint8_t* compressed) const;

  std::string file_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::map<std::uint16_t, std::string> schemas_;  // id -> name
  std::map<std::uint16_t, TopicInfo> channels_;
  std::vector<Chunk> chunks_;
  std::vector<Entry> entries_;
  std::optional<std::string> truncated_;
  std::vector<bool> wanted_;  // by channel id: defined and asked for
  std::size_t position_ = 0;
  std::uint32_t cached_chunk_ = kDirect;
  std::vector<std::uint8_t> cache_;
};

// Writes one .mcap file: zstd-compressed chunks of about 1 MiB with their message
// indexes, then the summary (schemas, channels with their final offered QoS, statistics,
// chunk indexes, summary offsets). A topic's schema and channel are written before its
// first message; its schema holds the ROS 2 IDL of the type where storey knows it
// (`ros2idl`), else no schema text.
class McapFileWriter {
 public:
  // Creates `file` (throws BagError naming it).
  explicit McapFileWriter(const std::string& file);
  ~McapFileWriter();
  McapFileWriter(const McapFileWriter&) = delete;
  McapFileWriter& operator=(const McapFileWriter&) = delete;

  // Returns the channel id of a new topic.
  std::uint16_t addTopic(const TopicInfo& topic);
  // Until the topic's first message (its channel record is then written, and all records
  // of a channel must be identical); ignored after.
  void setOfferedQos(std::uint16_t channel, const std::string& offered_qos_profiles);
  void write(std::uint16_t channel, std::int64_t stamp, const std::uint8_t* data, std::size_t size);
  // Writes the last chunk, the summary and the footer; throws BagError on a write error.
  void close();

 private:
  struct Channel {
    TopicInfo topic;
    std::uint16_t schema = 0;
    bool written = false;  // its schema and channel records are in the file
    std::uint32_t sequence = 0;
    std::uint64_t count = 0;
  };
  void flushChunk();
  void put(const std::vector<std::uint8_t>& bytes);

  std::string file_;
  std::ofstream out_;
  std::uint64_t offset_ = 0;
  std::map<std::string, std::uint16_t> schema_ids_;  // type -> id
  std::vector<Channel> channels_;                    // id = index + 1
  std::vector<std::uint8_t> chunk_;                  // uncompressed records
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::int64_t chunk_start_ = 0, chunk_end_ = 0;
  std::uint64_t messages_in_chunk_ = 0;
  std::vector<std::uint8_t> chunk_indexes_;  // Chunk Index records for the summary
  std::uint32_t chunk_count_ = 0;
  std::uint64_t messages_ = 0;
  std::int64_t first_ = 0, last_ = 0;
  bool closed_ = false;
};

// The IDL text of every type storey defines, by ROS type name (generated from idl/).
const std::map<std::string, std::string>& messageIdls();

// The ROS 2 IDL text of a type storey defines, each type it includes after it under a
// line of 80 '=' and "IDL: <type>" (MCAP's `ros2idl` layout); empty when storey does not
// know the type.
std::string ros2IdlSchema(const std::string& type);

}  // namespace storey::bag::detail
