#include "storey/common/record_file.h"

#include <unistd.h>
#include <zlib.h>

#include <fstream>
#include <iterator>
#include <sstream>

#include "storey/common/log.h"

namespace storey::common {
namespace {

constexpr std::size_t kMagicSize = 8;
constexpr std::uint32_t kRecordMagic = 0x4A524543;  // "JREC"
constexpr std::size_t kFrameHeader = 8;            // record magic + payload length
constexpr std::size_t kFrameTrailer = 4;           // crc32 of the payload
constexpr std::uint32_t kMaxPayload = 1u << 30;

std::uint32_t checksum(const std::uint8_t* data, std::size_t size) {
  return static_cast<std::uint32_t>(crc32(0L, data, static_cast<uInt>(size)));
}

std::string at(const std::string& path, const std::string& what, std::size_t offset) {
  std::ostringstream out;
  out << path << ": " << what << " record at offset " << offset;
  return out.str();
}

}  // namespace

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

RecordFileReadResult readRecordFile(const std::string& path, const char* magic, const std::string& what,
                                    const RecordHandler& on_record) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open the " + what);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  RecordFileReadResult result;
  if (bytes.empty()) return result;
  if (bytes.size() < kMagicSize || std::memcmp(bytes.data(), magic, kMagicSize) != 0) {
    if (bytes.size() < kMagicSize && std::memcmp(bytes.data(), magic, bytes.size()) == 0) {
      result.torn_tail = true;  // torn while creating
      return result;
    }
    throw std::runtime_error(path + ": not a storey " + what);
  }
  std::size_t pos = kMagicSize;
  result.valid_bytes = pos;
  while (pos < bytes.size()) {
    const std::size_t left = bytes.size() - pos;
    auto torn = [&](const std::string& why) {
      logWarn(str(path, ": dropping a torn last record at offset ", pos, " (", why, ")"));
      result.torn_tail = true;
    };
    if (left < kFrameHeader) {
      torn("short header");
      break;
    }
    std::uint32_t record_magic, length;
    std::memcpy(&record_magic, &bytes[pos], 4);
    std::memcpy(&length, &bytes[pos + 4], 4);
    if (record_magic != kRecordMagic || length > kMaxPayload)
      throw std::runtime_error(path + ": corrupt " + what + " record at offset " + std::to_string(pos));
    if (left < kFrameHeader + length + kFrameTrailer) {
      torn("short record");
      break;
    }
    const std::uint8_t* payload = &bytes[pos + kFrameHeader];
    std::uint32_t crc;
    std::memcpy(&crc, payload + length, 4);
    const bool last = pos + kFrameHeader + length + kFrameTrailer == bytes.size();
    if (crc != checksum(payload, length)) {
      if (last) {
        torn("checksum mismatch");
        break;
      }
      throw std::runtime_error(at(path, what, pos) + " fails its checksum");
    }
    try {
      on_record(payload, length);
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(at(path, what, pos) + ": " + e.what());
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(at(path, what, pos) + ": " + e.what());
    }
    ++result.records;
    pos += kFrameHeader + length + kFrameTrailer;
    result.valid_bytes = pos;
  }
  return result;
}

RecordFileWriter::RecordFileWriter(const std::string& path, const char* magic, const std::string& what, bool sync,
                                   const RecordHandler& on_existing)
    : path_(path), what_(what), sync_(sync) {
  std::uint64_t valid = 0;
  if (std::ifstream(path).good()) {
    const RecordFileReadResult read = readRecordFile(path, magic, what, on_existing);
    existing_records_ = read.records;
    had_torn_tail_ = read.torn_tail;
    valid = read.valid_bytes;
    if (truncate(path.c_str(), static_cast<off_t>(valid)) != 0)
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
  const std::uint32_t length = static_cast<std::uint32_t>(payload.size());
  const std::uint32_t crc = checksum(payload.data(), payload.size());
  std::vector<std::uint8_t> frame(kFrameHeader + payload.size() + kFrameTrailer);
  std::memcpy(&frame[0], &kRecordMagic, 4);
  std::memcpy(&frame[4], &length, 4);
  std::memcpy(&frame[8], payload.data(), payload.size());
  std::memcpy(&frame[8 + payload.size()], &crc, 4);
  if (std::fwrite(frame.data(), 1, frame.size(), file_) != frame.size() || std::fflush(file_) != 0)
    throw std::runtime_error(path_ + ": " + what_ + " write failed");
  if (sync_ && fdatasync(fileno(file_)) != 0) throw std::runtime_error(path_ + ": " + what_ + " sync failed");
}

}  // namespace storey::common
