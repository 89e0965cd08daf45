// Append-only files of records, each framed with a magic number, its length and a CRC32,
// for state that must survive a crash: the graph server's journal and the floor mapper's
// input log. A torn last record (a crash mid-write) is detected, dropped with a warning
// and cut off; damage before the end (a record whose header, length or checksum fails
// with more data behind it) is an error naming the file and offset, and the file is
// never cut there. `storey journal check|salvage` reports a file's state and copies its
// intact prefix.
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

// A record file's bytes, from a file or from memory (tests, fuzzing).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  // Reads exactly `n` bytes at `offset` (within size()); throws std::runtime_error if it cannot.
  virtual void read(std::uint64_t offset, std::uint8_t* out, std::size_t n) const = 0;
};

class MemoryByteSource : public ByteSource {
 public:
  MemoryByteSource(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::uint8_t* out, std::size_t n) const override;

 private:
  const std::uint8_t* data_;
  std::size_t size_;
};

// Where a record file's intact prefix ends.
enum class RecordFileEnd {
  kIntact,    // every byte belongs to an intact record
  kTornTail,  // the last record is incomplete (a crash mid-write): it can be cut off
  kDamaged,   // a record before the end fails its framing, checksum or decoding
};

struct RecordFileScan {
  RecordFileEnd end = RecordFileEnd::kIntact;
  std::size_t records = 0;        // intact records in the prefix
  std::uint64_t valid_bytes = 0;  // length of the intact prefix (file magic and records)
  std::uint64_t file_bytes = 0;
  std::string problem;  // what is wrong at valid_bytes (torn or damaged)
  // kDamaged: the first intact record found after the damage (0: none) and how many
  // intact records follow from there.
  std::uint64_t next_intact_offset = 0;
  std::size_t intact_after = 0;
};

// Largest payload a record may have; longer length fields are damage.
inline constexpr std::uint32_t kMaxRecordPayload = 256u << 20;

// Passes every record of the intact prefix to `on_record` (nullptr: frames only) and says
// where and why the prefix ends; an exception from `on_record` ends it as kDamaged.
// Throws std::runtime_error naming `name` only for a file of another kind (its first 8
// bytes are not `magic`). Reads one record at a time: memory stays within the largest
// record, whatever the length fields claim.
RecordFileScan scanRecords(const ByteSource& source, const std::string& name, const char* magic,
                           const std::string& what, const RecordHandler& on_record);
// The same for a file, refused by name unless it is a regular file.
RecordFileScan scanRecordFile(const std::string& path, const char* magic, const std::string& what,
                              const RecordHandler& on_record);
// The message for a damaged file: offset, why, what is intact, and how to recover.
std::string describeDamage(const std::string& path, const std::string& what,
                           const RecordFileScan& scan);

struct RecordFileReadResult {
  std::size_t records = 0;
  bool torn_tail = false;         // a partial last record was found (and dropped)
  std::uint64_t valid_bytes = 0;  // length of the intact prefix
};

// Thrown for a record file damaged before its end: such a file is never cut short.
class RecordFileDamaged : public std::runtime_error {
 public:
  explicit RecordFileDamaged(const std::string& what) : std::runtime_error(what) {}
};

// Passes every intact record to `on_record`, in order. `magic` (8 characters) names the
// kind of file, `what` names it in messages ("journal"). A torn last record is dropped
// with a warning. Throws RecordFileDamaged naming the file and offset for damage before
// the end, std::runtime_error for a file of another kind or a special file.
RecordFileReadResult readRecordFile(const std::string& path, const char* magic, const std::string& what,
                                    const RecordHandler& on_record);

// Writes the intact prefix of `in` (every record before a torn tail or damage) to a new
// file `out`, which must not exist. `on_record` may refuse a record by throwing (the copy
// then ends before it). Returns the scan of `in`.
RecordFileScan salvageRecordFile(const std::string& in, const std::string& out, const char* magic,
                                 const std::string& what, const RecordHandler& on_record);

class RecordFileWriter {
 public:
  // Opens (creating if needed) for appending. An existing file is first read (each record
  // passed to `on_existing`); a torn tail is cut off, damage before the end is thrown
  // (RecordFileDamaged) and the file left as it is. Every append reaches the kernel before it
  // returns (it survives the process being killed); sync() makes it durable.
  RecordFileWriter(const std::string& path, const char* magic, const std::string& what,
                   const RecordHandler& on_existing);
  ~RecordFileWriter();
  RecordFileWriter(const RecordFileWriter&) = delete;
  RecordFileWriter& operator=(const RecordFileWriter&) = delete;

  // Throws std::invalid_argument for a payload over kMaxRecordPayload.
  void append(const std::vector<std::uint8_t>& payload);
  // Makes every record appended so far durable (one fdatasync, none when nothing is new).
  void sync();
  std::uint64_t syncs() const { return syncs_; }
  bool hadTornTail() const { return had_torn_tail_; }
  std::size_t existingRecords() const { return existing_records_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string what_;
  std::FILE* file_ = nullptr;
  bool had_torn_tail_ = false;
  std::size_t existing_records_ = 0;
  bool unsynced_ = false;
  std::uint64_t syncs_ = 0;
};

}  // namespace storey::common
