#include "storey/bag/mcap_file.h"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <utility>

#include "storey/bag/bag_error.h"
#include "storey/bag/mcap_records.h"
#include "storey/common/file_checks.h"

namespace storey::bag::detail {

using namespace mcap;  // NOLINT(google-build-using-namespace): this file's own format

std::uint32_t mcap::crc32Of(const std::uint8_t* p, std::size_t n) {
  uLong crc = crc32(0L, Z_NULL, 0);
  while (n > 0) {  // zlib takes 32-bit lengths
    const auto step = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    crc = crc32(crc, p, step);
    p += step;
    n -= step;
  }
  return static_cast<std::uint32_t>(crc);
}

namespace {

// A record's fields, little endian, each checked against the record's end.
class Fields {
 public:
  // `where` names the record in errors.
  Fields(const std::uint8_t* data, std::uint64_t size, const std::string& file, std::string where)
      : data_(data), size_(size), file_(file), where_(std::move(where)) {}
  std::uint64_t uint(int bytes) {
    need(static_cast<std::uint64_t>(bytes));
    const std::uint64_t v = littleEndian(data_ + pos_, bytes);
    pos_ += static_cast<std::uint64_t>(bytes);
    return v;
  }
  std::string text() {
    const std::uint64_t n = uint(4);
    need(n);
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }
  std::map<std::string, std::string> textMap() {
    const std::uint64_t n = uint(4);
    need(n);
    Fields inner(data_ + pos_, n, file_, where_);
    pos_ += n;
    std::map<std::string, std::string> out;
    while (inner.pos_ < n) {
      std::string key = inner.text();
      out[key] = inner.text();
    }
    return out;
  }
  // The offset of the next field and the bytes left.
  std::uint64_t position() const { return pos_; }
  std::uint64_t left() const { return size_ - pos_; }
  void skip(std::uint64_t n) {
    need(n);
    pos_ += n;
  }

 private:
  void need(std::uint64_t n) const {
    if (size_ - pos_ < n) throw BagError(file_, where_ + " ends inside a field");
  }
  const std::uint8_t* data_;
  std::uint64_t size_, pos_ = 0;
  const std::string& file_;
  std::string where_;
};

// `in`: the `in_size` compressed bytes of a chunk's records.
std::vector<std::uint8_t> decompress(const std::string& compression, const std::uint8_t* in,
                                     std::size_t in_size, std::uint64_t size,
                                     const std::string& file, std::uint64_t at) {
  const std::string where = "the chunk at byte " + std::to_string(at);
  std::vector<std::uint8_t> out(size);
  if (compression.empty()) {
    if (in_size != size) throw BagError(file, where + " holds a size other than it declares");
    return std::vector<std::uint8_t>(in, in + in_size);
  }
  if (compression == "zstd") {
    const std::size_t n = ZSTD_decompress(out.data(), out.size(), in, in_size);
    if (ZSTD_isError(n) || n != size)
      throw BagError(file, where + " does not decompress (zstd" +
                               (ZSTD_isError(n) ? std::string(": ") + ZSTD_getErrorName(n) : "") +
                               ")");
    return out;
  }
  if (compression == "lz4") {
    LZ4F_dctx* context = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&context, LZ4F_VERSION)))
      throw BagError(file, where + ": no lz4 decompression context");
    std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> owner(
        context, LZ4F_freeDecompressionContext);
    std::size_t read = 0, written = 0, hint = 1;
    while (hint != 0 && read < in_size) {
      std::size_t src = in_size - read, dst = out.size() - written;
      hint = LZ4F_decompress(context, out.data() + written, &dst, in + read, &src, nullptr);
      if (LZ4F_isError(hint))
        throw BagError(file, where + " does not decompress (lz4: " + LZ4F_getErrorName(hint) + ")");
      read += src;
      written += dst;
      if (src == 0 && dst == 0) break;
    }
    if (hint != 0 || written != size)
      throw BagError(file, where + " does not decompress (lz4: " + std::to_string(written) +
                               " of " + std::to_string(size) + " bytes)");
    return out;
  }
  throw BagError(
      file, where + " uses compression '" + compression + "' (storey reads none, zstd and lz4)");
}

}  // namespace

namespace {

// An .idl file without its include guards (#ifndef, #define, #endif lines): ROS 2's own
// .idl files have none, and ros2idl readers take only #include.
std::string withoutGuards(const std::string& idl) {
  std::string out;
  std::size_t begin = 0;
  while (begin < idl.size()) {
    std::size_t end = idl.find('\n', begin);
    end = end == std::string::npos ? idl.size() : end + 1;
    const std::string line = idl.substr(begin, end - begin);
    if (line.rfind("#ifndef", 0) != 0 && line.rfind("#define", 0) != 0 &&
        line.rfind("#endif", 0) != 0)
      out += line;
    begin = end;
  }
  return out;
}

}  // namespace

std::string ros2IdlSchema(const std::string& type) {
  const auto& idls = messageIdls();
  const auto main = idls.find(type);
  if (main == idls.end()) return "";
  std::string out = withoutGuards(main->second);
  // The types it includes, depth first, each once.
  std::vector<std::string> pending{type}, seen{type};
  while (!pending.empty()) {
    const std::string& text = idls.at(pending.back());
    pending.pop_back();
    for (std::size_t at = text.find("#include \""); at != std::string::npos;
         at = text.find("#include \"", at + 1)) {
      const std::size_t begin = at + 10, end = text.find(".idl\"", begin);
      if (end == std::string::npos) continue;
      const std::string dependency = text.substr(begin, end - begin);
      if (!idls.count(dependency) || std::find(seen.begin(), seen.end(), dependency) != seen.end())
        continue;
      seen.push_back(dependency);
      pending.push_back(dependency);
      out += "\n" + std::string(80, '=') + "\nIDL: " + dependency + "\n" +
             withoutGuards(idls.at(dependency));
    }
  }
  return out;
}

bool looksLikeMcap(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::uint8_t magic[8] = {};
  return in.read(reinterpret_cast<char*>(magic), 8) && std::memcmp(magic, kMagic, 8) == 0;
}

McapFileReader::McapFileReader(const std::string& file) : file_(file) {
  try {
    size_ = common::requireRegularFile(file, "MCAP file");
  } catch (const std::runtime_error& e) {
    throw BagError(file, std::string(e.what()).substr(file.size() + 2));
  }
  in_.open(file, std::ios::binary);
  std::uint8_t magic[8] = {};
  if (!in_ || !in_.read(reinterpret_cast<char*>(magic), 8) || std::memcmp(magic, kMagic, 8) != 0)
    throw BagError(file, "not an MCAP file (no MCAP magic at its start)");
  scan();
  std::stable_sort(entries_.begin(), entries_.end(),
                   [](const Entry& a, const Entry& b) { return a.stamp < b.stamp; });
  start({});
}

void McapFileReader::scan() {
  std::uint64_t at = 8;
  std::vector<std::uint8_t> content;
  while (true) {
    std::uint8_t head[9];
    if (size_ - at < 9) {
      truncated_ = "cut short at byte " + std::to_string(at) + " (no footer)";
      return;
    }
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(reinterpret_cast<char*>(head), 9);
    const auto op = head[0];
    const std::uint64_t length = littleEndian(head + 1, 8);
    if (length > size_ - at - 9) {
      truncated_ = "cut short inside the record at byte " + std::to_string(at);
      return;
    }
    if (op == kFooter || op == kDataEnd) return;
    const std::uint64_t body = at + 9;
    if (op == kMessage) {  // only the header: the data is read when asked for
      std::uint8_t fields[kMessageHeader];
      if (length < kMessageHeader)
        throw BagError(file_, "the message record at byte " + std::to_string(at) + " is too short");
      in_.read(reinterpret_cast<char*>(fields), kMessageHeader);
      entries_.push_back({static_cast<std::int64_t>(littleEndian(fields + 6, 8)), kDirect,
                          static_cast<std::uint16_t>(littleEndian(fields, 2)),
                          body + kMessageHeader, length - kMessageHeader});
    } else if (op == kSchema || op == kChannel || op == kChunk) {
      content.resize(length);
      in_.read(reinterpret_cast<char*>(content.data()), static_cast<std::streamsize>(length));
      if (!in_) throw BagError(file_, "read error at byte " + std::to_string(at));
      if (op == kChunk) {
        Fields f(content.data(), length, file_, "the chunk at byte " + std::to_string(at));
        f.uint(8);
        f.uint(8);
        Chunk chunk;
        chunk.uncompressed = f.uint(8);
        chunk.crc = static_cast<std::uint32_t>(f.uint(4));
        chunk.compression = f.text();
        chunk.compressed = f.uint(8);
        chunk.offset = body + f.position();
        f.skip(chunk.compressed);
        if (chunk.uncompressed > kMaxMcapChunkBytes)
          throw BagError(file_, "the chunk at byte " + std::to_string(at) + " declares " +
                                    std::to_string(chunk.uncompressed) + " bytes (at most " +
                                    std::to_string(kMaxMcapChunkBytes) + ")");
        chunks_.push_back(chunk);
        // Unpacked from the bytes read here, not read from the file again.
        readRecords(unpackChunk(chunk, content.data() + (chunk.offset - body)),
                    static_cast<std::uint32_t>(chunks_.size() - 1), at);
      } else {
        // A schema or channel record alone: the same parser as inside chunks.
        std::vector<std::uint8_t> one(head, head + 9);
        one.insert(one.end(), content.begin(), content.end());
        readRecords(one, kDirect, at);
      }
    }
    at = body + length;
  }
}

// Schema, channel and message records of a chunk (or one record outside chunks), which
// is at byte `file_at` of the file.
void McapFileReader::readRecords(const std::vector<std::uint8_t>& records, std::uint32_t chunk,
                                 std::uint64_t file_at) {
  const std::string in_chunk =
      chunk == kDirect ? "" : " of the chunk at byte " + std::to_string(file_at);
  std::uint64_t at = 0;
  while (at < records.size()) {
    const std::string where =
        "the record at byte " + std::to_string(chunk == kDirect ? file_at : at) + in_chunk;
    if (records.size() - at < 9) throw BagError(file_, where + " is cut inside its header");
    const std::uint8_t op = records[at];
    const std::uint64_t length = littleEndian(records.data() + at + 1, 8);
    if (length > records.size() - at - 9)
      throw BagError(file_, where + " runs past the chunk's end");
    Fields f(records.data() + at + 9, length, file_, where);
    if (op == kSchema) {
      const auto id = static_cast<std::uint16_t>(f.uint(2));
      schemas_[id] = f.text();
    } else if (op == kChannel) {
      const auto id = static_cast<std::uint16_t>(f.uint(2));
      const auto schema = static_cast<std::uint16_t>(f.uint(2));
      TopicInfo topic;
      topic.name = f.text();
      topic.serialization_format = f.text();
      const auto metadata = f.textMap();
      const auto found = schemas_.find(schema);
      if (found == schemas_.end())
        throw BagError(file_, "channel " + topic.name + " names schema " + std::to_string(schema) +
                                  " before any record defines it");
      topic.type = found->second;
      if (const auto qos = metadata.find("offered_qos_profiles"); qos != metadata.end())
        topic.offered_qos_profiles = qos->second;
      channels_[id] = topic;
    } else if (op == kMessage && chunk != kDirect) {
      const auto channel = static_cast<std::uint16_t>(f.uint(2));
      f.uint(4);
      const auto stamp = static_cast<std::int64_t>(f.uint(8));
      f.uint(8);
      entries_.push_back({stamp, chunk, channel, at + 9 + kMessageHeader, f.left()});
    }
    at += 9 + length;
  }
}

std::vector<std::uint8_t> McapFileReader::chunkRecords(std::uint32_t index) {
  const Chunk& c = chunks_[index];
  std::vector<std::uint8_t> compressed(c.compressed);
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(c.offset));
  in_.read(reinterpret_cast<char*>(compressed.data()), static_cast<std::streamsize>(c.compressed));
  if (!in_) throw BagError(file_, "read error at byte " + std::to_string(c.offset));
  return unpackChunk(c, compressed.data());
}

std::vector<std::uint8_t> McapFileReader::unpackChunk(const Chunk& c,
                                                      const std::uint8_t* compressed) const {
  std::vector<std::uint8_t> records =
      decompress(c.compression, compressed, c.compressed, c.uncompressed, file_, c.offset);
  if (c.crc != 0 && crc32Of(records.data(), records.size()) != c.crc)
    throw BagError(file_, "the chunk at byte " + std::to_string(c.offset) +
                              " does not match its CRC (the file is damaged)");
  return records;
}

std::map<std::uint16_t, McapFileReader::Count> McapFileReader::counts() const {
  std::map<std::uint16_t, Count> out;
  for (const Entry& e : entries_) {  // in time order
    Count& c = out[e.channel];
    if (c.messages++ == 0) c.first = e.stamp;
    c.last = e.stamp;
  }
  return out;
}

void McapFileReader::start(const std::vector<std::uint16_t>& channels) {
  // Only channels the file defines: a message of no channel is skipped.
  wanted_.assign(1u << 16, false);
  for (const auto& [id, topic] : channels_)
    wanted_[id] =
        channels.empty() || std::find(channels.begin(), channels.end(), id) != channels.end();
  position_ = 0;
}

bool McapFileReader::next(std::uint16_t& channel, std::int64_t& stamp,
                          std::vector<std::uint8_t>& data) {
  while (position_ < entries_.size() && !wanted_[entries_[position_].channel]) ++position_;
  if (position_ >= entries_.size()) {
    if (position_ == entries_.size() && truncated_) {
      ++position_;  // thrown once
      throw BagError(file_, *truncated_ + "; the messages before it were read");
    }
    return false;
  }
  const Entry& e = entries_[position_++];
  channel = e.channel;
  stamp = e.stamp;
  if (e.chunk == kDirect) {
    data.resize(e.size);
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(e.offset));
    in_.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(e.size));
    if (!in_) throw BagError(file_, "read error at byte " + std::to_string(e.offset));
    return true;
  }
  if (cached_chunk_ != e.chunk) {
    cache_ = chunkRecords(e.chunk);
    cached_chunk_ = e.chunk;
  }
  data.assign(cache_.begin() + static_cast<std::ptrdiff_t>(e.offset),
              cache_.begin() + static_cast<std::ptrdiff_t>(e.offset + e.size));
  return true;
}

}  // namespace storey::bag::detail
