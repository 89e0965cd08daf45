// The journal's file framing (storey::common scanRecords with the journal's decoder):
// raw bytes, or a valid three-record journal patched by the input (fuzz_support.h). Besides
// never crashing, the scan must be consistent: its intact prefix lies within the file,
// covers it all when the file is called intact, and scans again as intact with the same
// records (what `storey journal salvage` copies); damage reports an intact record after
// the prefix or none. A violation traps.
#include <zlib.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "fuzz_support.h"
#include "storey/building/journal.h"
#include "storey/common/record_file.h"

namespace {

using storey::common::RecordFileEnd;
using storey::common::RecordFileScan;

constexpr char kMagic[8] = {'S', 'T', 'O', 'R', 'E', 'Y', 'J', '1'};

// A record framed as RecordFileWriter frames it: magic "JREC", length, payload, zlib's CRC32.
void frame(std::vector<std::uint8_t>& file, const std::vector<std::uint8_t>& payload) {
  const std::uint32_t magic = 0x4A524543, length = static_cast<std::uint32_t>(payload.size());
  const auto crc =
      static_cast<std::uint32_t>(crc32(0L, payload.data(), static_cast<uInt>(payload.size())));
  const auto put = [&](std::uint32_t v) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    file.insert(file.end(), p, p + 4);
  };
  put(magic);
  put(length);
  file.insert(file.end(), payload.begin(), payload.end());
  put(crc);
}

std::vector<std::uint8_t> sampleJournal() {
  using namespace storey;
  std::vector<std::uint8_t> file(kMagic, kMagic + 8);
  building::FloorGraphDelta delta;
  delta.robot = "robot1";
  delta.graph_id = 1;
  delta.sequence = 0;
  floor::FloorNode node;
  node.scan.ranges = {1.0f, 2.0f, 3.0f};
  delta.new_nodes.push_back(node);
  frame(file, building::encodeRecord(building::JournalRecord(delta)));
  building::InterGraphConstraint c;
  c.graph_from = 1;
  c.graph_to = 1;
  frame(file, building::encodeRecord(building::JournalRecord(c)));
  building::ConstraintRetraction r;
  r.graph_from = 1;
  r.graph_to = 1;
  r.reason = "x";
  frame(file, building::encodeRecord(building::JournalRecord(r)));
  return file;
}

RecordFileScan scan(const std::vector<std::uint8_t>& bytes) {
  const storey::common::MemoryByteSource source(bytes.data(), bytes.size());
  return storey::common::scanRecords(source, "fuzz", kMagic, "journal",
                                     [](const std::uint8_t* payload, std::size_t size) {
                                       (void)storey::building::decodeRecord(payload, size);
                                     });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::uint8_t> sample = sampleJournal();
  std::vector<std::uint8_t> bytes;
  if (size > 0 && (data[0] & 1))
    bytes = storey::fuzz::patchSample(sample, data + 1, size - 1);
  else if (size > 0)
    bytes.assign(data + 1, data + size);
  RecordFileScan result;
  try {
    result = scan(bytes);
  } catch (const std::runtime_error&) {
    return 0;  // not a journal
  }
  if (result.valid_bytes > bytes.size() || result.file_bytes != bytes.size()) __builtin_trap();
  if (result.end == RecordFileEnd::kIntact && result.valid_bytes != bytes.size() && !bytes.empty())
    __builtin_trap();
  if (result.end == RecordFileEnd::kDamaged && result.next_intact_offset != 0 &&
      result.next_intact_offset <= result.valid_bytes)
    __builtin_trap();
  // The intact prefix is a journal of its own with the same records.
  if (result.valid_bytes >= 8) {
    const std::vector<std::uint8_t> prefix(bytes.begin(),
                                           bytes.begin() + static_cast<long>(result.valid_bytes));
    const RecordFileScan again = scan(prefix);
    if (again.end != RecordFileEnd::kIntact || again.records != result.records) __builtin_trap();
  }
  return 0;
}
