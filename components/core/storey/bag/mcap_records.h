// MCAP's record layout shared by McapFileReader and McapFileWriter (mcap_file.h): magic,
// opcodes, little-endian fields. Internal to the bag library.
#pragma once

#include <cstddef>
#include <cstdint>

namespace storey::bag::detail::mcap {

constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0b,
  kSummaryOffset = 0x0e,
  kDataEnd = 0x0f,
};
constexpr std::size_t kMessageHeader = 2 + 4 + 8 + 8;  // channel, sequence, log and publish time
inline std::uint64_t littleEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

// CRC-32 as MCAP uses it (zlib's).
std::uint32_t crc32Of(const std::uint8_t* p, std::size_t n);

}  // namespace storey::bag::detail::mcap
