#include "storey/common/record_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>

#include "storey/common/file_checks.h"
#include "storey/common/log.h"

namespace storey::common {
namespace {

constexpr std::size_t kMagicSize = 8;
constexpr std::uint32_t kRecordMagic = 0x4A524543;  // "JREC"
constexpr std::size_t kFrameHeader = 8;            // record magic + payload length
constexpr std::size_t kFrameTrailer = 4;           // crc32 of the payload
constexpr std::size_t kChunk = 1 << 16;            // bytes read at a time when searching

std::uint32_t checksum(const std::uint8_t* data, std::size_t size) {
  return static_cast<std::uint32_t>(crc32(0L, data, static_cast<uInt>(size)));
}

class FileSource : public ByteSource {
 public:
  FileSource(const std::string& path, const std::string& what) : path_(path) {
    requireRegularFile(path, what);
    fd_ = ::open(path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    struct stat st {};
    if (fd_ < 0 || ::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
      if (fd_ >= 0) ::close(fd_);
      throw std::runtime_error(path + ": cannot open the " + what);
    }
    size_ = static_cast<std::uint64_t>(st.st_size);
  }
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::uint8_t* out, std::size_t n) const override {
    while (n > 0) {
      const ssize_t got = ::pread(fd_, out, n, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0)
        throw std::runtime_error(path_ + ": read failed at offset " + std::to_string(offset));
      out += got;
      offset += static_cast<std::uint64_t>(got);
      n -= static_cast<std::size_t>(got);
    }
  }

 private:
  std::string path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

struct Header {
  std::uint32_t magic = 0;
  std::uint32_t length = 0;
};

Header readHeader(const ByteSource& source, std::uint64_t pos) {
  std::uint8_t bytes[kFrameHeader];
  source.read(pos, bytes, kFrameHeader);
  Header h;
  std::memcpy(&h.magic, bytes, 4);
  std::memcpy(&h.length, bytes + 4, 4);
  return h;
}

// Length of the intact frame at `pos`, or 0: record magic, a length that fits, and a
// matching checksum (computed in chunks: nothing the length claims is allocated).
std::uint64_t intactFrameAt(const ByteSource& source, std::uint64_t pos) {
  const std::uint64_t size = source.size();
  if (size - pos < kFrameHeader + kFrameTrailer) return 0;
  const Header h = readHeader(source, pos);
  if (h.magic != kRecordMagic || h.length > kMaxRecordPayload) return 0;
  const std::uint64_t frame = kFrameHeader + std::uint64_t{h.length} + kFrameTrailer;
  if (frame > size - pos) return 0;
  std::vector<std::uint8_t> chunk(std::min<std::uint64_t>(h.length, kChunk));
  uLong crc = crc32(0L, Z_NULL, 0);
  for (std::uint64_t done = 0; done < h.length;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, h.length - done));
    source.read(pos + kFrameHeader + done, chunk.data(), n);
    crc = crc32(crc, chunk.data(), static_cast<uInt>(n));
    done += n;
  }
  std::uint8_t stored[4];
  source.read(pos + kFrameHeader + h.length, stored, 4);
  std::uint32_t expected;
  std::memcpy(&expected, stored, 4);
  return static_cast<std::uint32_t>(crc) == expected ? frame : 0;
}

// The first intact frame starting after `from` (0: none), and how many intact frames
// follow each other from there.
void findIntactAfter(const ByteSource& source, std::uint64_t from, RecordFileScan& scan) {
  const std::uint64_t size = source.size();
  std::uint8_t magic[4];
  std::memcpy(magic, &kRecordMagic, 4);
  std::vector<std::uint8_t> chunk(kChunk + 3);
  for (std::uint64_t start = from + 1; start + 4 <= size; start += kChunk) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk + 3, size - start));
    source.read(start, chunk.data(), n);
    for (std::size_t i = 0; i + 4 <= n && i < kChunk; ++i) {
      if (std::memcmp(&chunk[i], magic, 4) != 0) continue;
      std::uint64_t pos = start + i;
      std::uint64_t frame = intactFrameAt(source, pos);
      if (frame == 0) continue;
      scan.next_intact_offset = pos;
      for (; frame > 0; frame = pos < size ? intactFrameAt(source, pos) : 0) {
        ++scan.intact_after;
        pos += frame;
      }
      return;
    }
  }
}

bool allZero(const ByteSource& source, std::uint64_t from) {
  std::vector<std::uint8_t> chunk(kChunk);
  for (std::uint64_t pos = from; pos < source.size(); pos += kChunk) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, source.size() - pos));
    source.read(pos, chunk.data(), n);
    if (std::any_of(chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(n),
                    [](std::uint8_t b) { return b; }))
      return false;
  }
  return true;
}

}  // namespace

void MemoryByteSource::read(std::uint64_t offset, std::uint8_t* out, std::size_t n) const {
  if (offset > size_ || n > size_ - offset) throw std::runtime_error("read past the end");
  if (n > 0) std::memcpy(out, data_ + offset, n);  // an empty payload's buffer may be null
}

std::string ByteDecoder::getString() {
  const auto n = get<std::uint32_t>();
  if (pos_ + n > size_) throw std::runtime_error("string runs past the record");
  std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
  pos_ += n;
  return s;
}

std::uint32_t ByteDecoder::getCount(std::size_t min_item_bytes) {
  const auto n = get<std::uint32_t>();
  if (static_cast<std::uint64_t>(n) * min_item_bytes > size_ - pos_)
    throw std::runtime_error("count larger than the record");
  return n;
}

RecordFileScan scanRecords(const ByteSource& source, const std::string& name, const char* magic,
                           const std::string& what, const RecordHandler& on_record) {
  RecordFileScan scan;
  const std::uint64_t size = source.size();
  scan.file_bytes = size;
  if (size == 0) return scan;
  std::uint8_t head[kMagicSize];
  const auto head_size = static_cast<std::size_t>(std::min<std::uint64_t>(size, kMagicSize));
  source.read(0, head, head_size);
  if (std::memcmp(head, magic, head_size) != 0)
    throw std::runtime_error(name + ": not a storey " + what);
  if (head_size < kMagicSize) {
    scan.end = RecordFileEnd::kTornTail;
    scan.problem = "the file header is incomplete";
    return scan;
  }
  std::uint64_t pos = kMagicSize;
  scan.valid_bytes = pos;
  auto stop = [&](RecordFileEnd end, const std::string& why) {
    scan.end = end;
    scan.problem = why;
    if (end == RecordFileEnd::kDamaged) findIntactAfter(source, pos, scan);
  };
  std::vector<std::uint8_t> payload;
  while (pos < size) {
    const std::uint64_t left = size - pos;
    if (left < kFrameHeader) {
      stop(RecordFileEnd::kTornTail, "an incomplete record header");
      break;
    }
    const Header h = readHeader(source, pos);
    if (h.magic != kRecordMagic || h.length > kMaxRecordPayload) {
      // A crash can leave a file extended with zeros that were never written.
      if (allZero(source, pos))
        stop(RecordFileEnd::kTornTail, "zero bytes where the last record should be");
      else if (h.magic != kRecordMagic)
        stop(RecordFileEnd::kDamaged, "no record header");
      else
        stop(RecordFileEnd::kDamaged, "its length field claims " + std::to_string(h.length) +
                                          " bytes, more than "
                                          "the " +
                                          std::to_string(kMaxRecordPayload) + " a record may hold");
      break;
    }
    const std::uint64_t frame = kFrameHeader + std::uint64_t{h.length} + kFrameTrailer;
    if (frame > left) {
      // Incomplete: a torn last record, unless an intact record follows (then the length
      // field itself is damaged).
      RecordFileScan probe;
      findIntactAfter(source, pos, probe);
      if (probe.next_intact_offset == 0) {
        stop(RecordFileEnd::kTornTail, "incomplete: " + std::to_string(left) + " of " +
                                           std::to_string(frame) + " bytes written");
      } else {
        scan.end = RecordFileEnd::kDamaged;
        scan.problem = "its length field claims " + std::to_string(h.length) +
                       " bytes, past the end of the file, yet an intact record follows";
        scan.next_intact_offset = probe.next_intact_offset;
        scan.intact_after = probe.intact_after;
      }
      break;
    }
    payload.resize(h.length);
    source.read(pos + kFrameHeader, payload.data(), h.length);
    std::uint8_t stored[4];
    source.read(pos + kFrameHeader + h.length, stored, 4);
    std::uint32_t crc;
    std::memcpy(&crc, stored, 4);
    if (crc != checksum(payload.data(), payload.size())) {
      // The last record may have been written in part (its tail zeros or stale bytes).
      if (frame == left)
        stop(RecordFileEnd::kTornTail, "the last record fails its checksum");
      else
        stop(RecordFileEnd::kDamaged, "fails its checksum");
      break;
    }
    if (on_record) {
      try {
        on_record(payload.data(), payload.size());
      } catch (const std::exception& e) {
        stop(RecordFileEnd::kDamaged, std::string("cannot be read: ") + e.what());
        break;
      }
    }
    ++scan.records;
    pos += frame;
    scan.valid_bytes = pos;
  }
  return scan;
}

RecordFileScan scanRecordFile(const std::string& path, const char* magic, const std::string& what,
                              const RecordHandler& on_record) {
  const FileSource source(path, what);
  return scanRecords(source, path, magic, what, on_record);
}

std::string describeDamage(const std::string& path, const std::string& what,
                           const RecordFileScan& scan) {
  std::string text = path + ": damaged " + what + " record at offset " +
                     std::to_string(scan.valid_bytes) + " (" + scan.problem + "), after " +
                     std::to_string(scan.records) + " intact records; ";
  if (scan.next_intact_offset > 0) {
    text += std::to_string(scan.intact_after) + " intact records follow from offset " +
            std::to_string(scan.next_intact_offset);
  } else {
    text += "no intact record follows";
  }
  return text + ". The file is left as it is: `storey journal salvage " + path +
         " NEW` copies the records before the damage";
}

RecordFileReadResult readRecordFile(const std::string& path, const char* magic,
                                    const std::string& what, const RecordHandler& on_record) {
  const RecordFileScan scan = scanRecordFile(path, magic, what, on_record);
  if (scan.end == RecordFileEnd::kDamaged)
    throw RecordFileDamaged(describeDamage(path, what, scan));
  if (scan.end == RecordFileEnd::kTornTail) {
    logWarn(str(path, ": dropping a torn last record at offset ", scan.valid_bytes, " (",
                scan.problem, ", ", scan.file_bytes - scan.valid_bytes, " bytes)"));
  }
  return {scan.records, scan.end == RecordFileEnd::kTornTail, scan.valid_bytes};
}

RecordFileScan salvageRecordFile(const std::string& in, const std::string& out, const char* magic,
                                 const std::string& what, const RecordHandler& on_record) {
  if (std::filesystem::exists(std::filesystem::symlink_status(out)))
    throw std::runtime_error(out + ": already exists (salvage writes a new file)");
  const FileSource source(in, what);
  const RecordFileScan scan = scanRecords(source, in, magic, what, on_record);
  const std::string part = out + ".part";
  std::FILE* file = std::fopen(part.c_str(), "wb");
  if (!file) throw std::runtime_error(out + ": cannot create");
  bool ok = true;
  std::vector<std::uint8_t> chunk(kChunk);
  // A file whose header was torn gets a whole one.
  if (scan.valid_bytes < kMagicSize) ok = std::fwrite(magic, 1, kMagicSize, file) == kMagicSize;
  for (std::uint64_t pos = 0; ok && pos < scan.valid_bytes; pos += kChunk) {
    const auto n =
        static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, scan.valid_bytes - pos));
    source.read(pos, chunk.data(), n);
    ok = std::fwrite(chunk.data(), 1, n, file) == n;
  }
  ok = ok && std::fflush(file) == 0 && fsync(fileno(file)) == 0;
  ok = std::fclose(file) == 0 && ok;
  if (!ok || std::rename(part.c_str(), out.c_str()) != 0) {
    std::remove(part.c_str());
    throw std::runtime_error(out + ": write failed");
  }
  return scan;
}

RecordFileWriter::RecordFileWriter(const std::string& path, const char* magic,
                                   const std::string& what, const RecordHandler& on_existing)
    : path_(path), what_(what) {
  std::uint64_t valid = 0;
  const std::string kind = fileKind(path);
  if (!kind.empty()) {
    const RecordFileReadResult read = readRecordFile(path, magic, what, on_existing);
    existing_records_ = read.records;
    had_torn_tail_ = read.torn_tail;
    valid = read.valid_bytes;
    if (read.torn_tail && truncate(path.c_str(), static_cast<off_t>(valid)) != 0)
      throw std::runtime_error(path + ": cannot cut off the torn " + what + " tail");
  }
  file_ = std::fopen(path.c_str(), "ab");
  if (!file_) throw std::runtime_error(path + ": cannot open the " + what + " for appending");
  if (valid == 0) {
    std::fwrite(magic, 1, kMagicSize, file_);
    std::fflush(file_);
  }
}

RecordFileWriter::~RecordFileWriter() {
  if (file_) std::fclose(file_);
}

void RecordFileWriter::append(const std::vector<std::uint8_t>& payload) {
  if (payload.size() > kMaxRecordPayload)
    throw std::invalid_argument(path_ + ": a " + what_ + " record of " +
                                std::to_string(payload.size()) + " bytes, more than the " +
                                std::to_string(kMaxRecordPayload) + " a record may hold");
  const std::uint32_t length = static_cast<std::uint32_t>(payload.size());
  const std::uint32_t crc = checksum(payload.data(), payload.size());
  std::vector<std::uint8_t> frame(kFrameHeader + payload.size() + kFrameTrailer);
  std::memcpy(&frame[0], &kRecordMagic, 4);
  std::memcpy(&frame[4], &length, 4);
  std::memcpy(&frame[8], payload.data(), payload.size());
  std::memcpy(&frame[8 + payload.size()], &crc, 4);
  if (std::fwrite(frame.data(), 1, frame.size(), file_) != frame.size() || std::fflush(file_) != 0)
    throw std::runtime_error(path_ + ": " + what_ + " write failed");
  unsynced_ = true;
}

void RecordFileWriter::sync() {
  if (!unsynced_) return;
  if (fdatasync(fileno(file_)) != 0)
    throw std::runtime_error(path_ + ": " + what_ + " sync failed");
  unsynced_ = false;
  ++syncs_;
}

}  // namespace storey::common
