// Helpers shared by the libFuzzer targets (tests/fuzz/*_fuzz.cpp).
//
// Binary formats are fuzzed two ways, chosen by the first input byte: even → the bytes
// are decoded as they are; odd → a valid encoded sample is taken and patched with the
// rest of the input (pairs of 16-bit offset and byte, then an optional truncation), so
// the fuzzer reaches past the header checks without needing a seed corpus.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace storey::fuzz {

inline std::vector<std::uint8_t> patchSample(std::vector<std::uint8_t> sample,
                                             const std::uint8_t* data, std::size_t size) {
  if (sample.empty()) return sample;
  std::size_t i = 0;
  // First two bytes: keep this many bytes of the sample (0xffff: all).
  if (size >= 2) {
    const std::size_t keep = (std::size_t(data[0]) << 8) | data[1];
    if (keep < sample.size()) sample.resize(keep);
    i = 2;
  }
  for (; i + 3 <= size && !sample.empty(); i += 3) {
    const std::size_t offset = ((std::size_t(data[i]) << 8) | data[i + 1]) % sample.size();
    sample[offset] = data[i + 2];
  }
  return sample;
}

// A private temporary folder for targets whose reader takes a path (made once).
std::string fuzzTempDir();

}  // namespace storey::fuzz
