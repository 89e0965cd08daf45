// Append-only files of records, each framed with a magic number, its length and a CRC32,
// for state that must survive a crash: the graph server's journal and the floor mapper's
// input log. A torn last record (a crash mid-write) is detected, dropped with a warning
// and cut off; corruption before the end is an error naming the file and offset.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace storey::common {

// Builds a record's payload from trivially copyable values (native byte order: the files
// stay on the machine that wrote them).
class ByteEncoder {
 public:
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  void putString(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
  std::vector<std::uint8_t> bytes;
};

// Reads a payload back; throws std::runtime_error when it ends early or a count cannot fit.
class ByteDecoder {
 public:
  ByteDecoder(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  T get() {
    if (pos_ + sizeof(T) > size_) throw std::runtime_error("record ends early");
    T value;
    std::memcpy(&value, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string getString();
  // A count of items of at least `min_item_bytes` each must fit in what is left.
  std::uint32_t getCount(std::size_t min_item_bytes);
  bool done() const { return pos_ == size_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

using RecordHandler = std::function<void(const std::uint8_t* payload, std::size_t size)>;

struct RecordFileReadResult {
  std::size_t records = 0;
  bool torn_tail = false;         // a partial last record was found (and dropped)
  std::uint64_t valid_bytes = 0;  // length of the intact prefix
};

// Passes every intact record to `on_record`, in order. `magic` (8 characters) names the
// kind of file, `what` names it in messages ("journal"). Throws std::runtime_error naming
// the file and offset for a file of another kind, a corrupt record that is not the last
// one, or an exception `on_record` throws.
RecordFileReadResult readRecordFile(const std::string& path, const char* magic, const std::string& what,
                                    const RecordHandler& on_record);

class RecordFileWriter {
 public:
  // Opens (creating if needed) for appending. An existing file is first read (each record
  // passed to `on_existing`); a torn tail is cut off. `sync` makes every append durable
  // (fdatasync) before it returns.
  RecordFileWriter(const std::string& path, const char* magic, const std::string& what, bool sync,
                   const RecordHandler& on_existing);
  ~RecordFileWriter();
  RecordFileWriter(const RecordFileWriter&) = delete;
  RecordFileWriter& operator=(const RecordFileWriter&) = delete;

  void append(const std::vector<std::uint8_t>& payload);
  bool hadTornTail() const { return had_torn_tail_; }
  std::size_t existingRecords() const { return existing_records_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string what_;
  bool sync_;
  std::FILE* file_ = nullptr;
  bool had_torn_tail_ = false;
  std::size_t existing_records_ = 0;
};

}  // namespace storey::common
