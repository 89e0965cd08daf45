// storey journal check|salvage: a graph server journal's (or a floor mapper input log's)
// state, and a copy of its intact records.
#include <iostream>

#include "args.h"
#include "storey/building/journal.h"
#include "storey/common/file_checks.h"
#include "storey/mapping/input_log.h"

namespace storey::cli {

extern const char* const summary_journal =
    "check a graph server journal or input log, or salvage its intact records";

namespace {

int printScanEnd(const std::string& path, const std::string& what,
                 const common::RecordFileScan& scan) {
  switch (scan.end) {
    case common::RecordFileEnd::kIntact:
      std::cout << "  end: intact\n";
      return 0;
    case common::RecordFileEnd::kTornTail:
      std::cout << "  end: torn last record at offset " << scan.valid_bytes << " (" << scan.problem
                << ", " << scan.file_bytes - scan.valid_bytes
                << " bytes): dropped when the file is opened\n";
      return 0;
    case common::RecordFileEnd::kDamaged:
      std::cout << "  end: " << common::describeDamage(path, what, scan) << "\n";
      return 1;
  }
  return 1;
}

}  // namespace

int run_journal(Args& args) {
  args.usage("check FILE | salvage FILE NEW",
             "check: reads a graph server journal (or a floor mapper's input log) and says what\n"
             "it holds and where its intact records end: intact, a torn last record (a crash\n"
             "mid-write; dropped when the file is opened again), or damage before the end (a\n"
             "record whose header, length or checksum fails with more data behind it: the graph\n"
             "server refuses such a file and leaves it as it is). Exit status 0 when the file\n"
             "can be opened, 1 when it is damaged.\n"
             "salvage: writes the records before the damage (or torn tail) to NEW, a new file, so\n"
             "that a server can start from it; what follows the damage is not copied.");
  if (!args.parse()) return 0;
  const std::string action = args.positional(0, "check or salvage");
  const std::string path = args.positional(1, "FILE");
  common::requireRegularFile(path, "journal or input log");
  const bool journal = building::looksLikeJournal(path);
  if (!journal && !mapping::looksLikeInputLog(path))
    throw std::runtime_error(path + ": not a storey journal or input log");
  const std::string what = journal ? "journal" : "input log";
  if (action == "check") {
    if (args.positionals().size() != 2) throw UsageError("check takes one FILE");
    if (journal) {
      const building::JournalCheck check = building::checkJournal(path);
      building::printJournalCheck(std::cout, path, check);
      return check.scan.end == common::RecordFileEnd::kDamaged ? 1 : 0;
    }
    const common::RecordFileScan scan = mapping::scanInputLog(path);
    std::cout << path << ": storey input log, " << common::byteCount(scan.file_bytes)
              << "\n  intact: " << scan.records << " inputs in the first " << scan.valid_bytes
              << " bytes\n";
    return printScanEnd(path, what, scan);
  }
  if (action == "salvage") {
    const std::string out = args.positional(2, "NEW");
    if (args.positionals().size() != 3) throw UsageError("salvage takes FILE and NEW");
    const common::RecordFileScan scan =
        journal ? building::salvageJournal(path, out) : mapping::salvageInputLog(path, out);
    std::cout << out << ": " << scan.records << " records (" << scan.valid_bytes << " bytes) of "
              << path << "\n";
    if (scan.end != common::RecordFileEnd::kIntact) {
      std::cout << "  left out: " << scan.file_bytes - scan.valid_bytes << " bytes from offset "
                << scan.valid_bytes << " (" << scan.problem << ")";
      if (scan.intact_after > 0)
        std::cout << ", among them " << scan.intact_after << " intact records from offset "
                  << scan.next_intact_offset;
      std::cout << "\n";
    }
    return 0;
  }
  throw UsageError("unknown action '" + action + "': check or salvage");
}

}  // namespace storey::cli
