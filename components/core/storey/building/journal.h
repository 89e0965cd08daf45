// The graph server's journal: every accepted floor-graph change, inter-floor constraint
// and constraint retraction is appended (length-prefixed, CRC-checked) before it is acknowledged,
// so a restarted server rebuilds exactly what it had. A torn last record (a crash mid-write) is
// detected, dropped with a warning and cut off; damage before the end is an error
// (common::RecordFileDamaged) naming the offset, and the file is left as it is.
#pragma once

#include <cstdint>
#include <cstdio>
#include <iosfwd>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/common/record_file.h"
#include "storey/floor/floor_graph.h"

namespace storey::building {

// What changed in one floor graph: new nodes and edges, and the current local poses of
// (some or all) of its nodes.
struct FloorGraphDelta {
  std::string robot;
  int graph_id = 0;
  int floor_id = 0;
  double floor_height = 0.0;
  std::uint32_t sequence = 0;
  std::vector<floor::FloorNode> new_nodes;
  std::vector<floor::FloorEdge> new_edges;
  std::map<int, geometry::Pose2> poses;
};

// Floor heights a floor graph may have (m): a floor_mapper's initial_height range.
inline constexpr double kMaxFloorHeight = 1e4;

// Applies a delta to a building graph, in place. Nodes already present are not
// duplicated (a re-sent update is harmless); a delta with an edge whose nodes are unknown
// is rejected whole, with an std::invalid_argument naming the graph and the edge, and
// changes nothing.
void applyDelta(BuildingGraph& building, const FloorGraphDelta& delta);
// The check applyDelta makes first (also: a floor height within +-kMaxFloorHeight, finite
// poses, stamps and edges): throws as it would, changes nothing.
void checkDelta(const BuildingGraph& building, const FloorGraphDelta& delta);

using JournalRecord = std::variant<FloorGraphDelta, InterGraphConstraint, ConstraintRetraction>;

// Applies any record to `building` (applyDelta, addConstraint or retractConstraint);
// throws as they do.
void applyRecord(BuildingGraph& building, const JournalRecord& record);

struct JournalReadResult {
  std::vector<JournalRecord> records;
  bool torn_tail = false;        // a partial last record was found (and cut off)
  std::uint64_t valid_bytes = 0;  // length of the intact prefix
};

// Reads every record. Throws common::RecordFileDamaged naming the file and offset for
// damage before the end, std::runtime_error for a file that is not a storey journal.
JournalReadResult readJournal(const std::string& path);

class JournalWriter {
 public:
  // Opens (creating if needed) for appending. An existing file is first read; a torn tail
  // is truncated away. An append survives the process being killed once it returns; with
  // `sync`, sync() makes every record appended so far durable against a power cut (one
  // fdatasync per call: group commit), without it sync() does nothing.
  JournalWriter(const std::string& path, bool sync);
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  // Records that were already in the file when it was opened.
  const std::vector<JournalRecord>& existing() const { return existing_; }
  bool hadTornTail() const { return file_.hadTornTail(); }
  void append(const JournalRecord& record);
  void sync() {
    if (sync_) file_.sync();
  }
  std::uint64_t syncs() const { return file_.syncs(); }
  const std::string& path() const { return file_.path(); }

 private:
  std::vector<JournalRecord> existing_;  // filled while file_ is opened (declared first)
  common::RecordFileWriter file_;
  bool sync_;
};

// A building rebuilt from a journal (storey export, storey match): every record applied
// in order; a record that cannot be applied is skipped and described in `skipped`
// ("record N: why"), the rest are kept.
struct JournalBuilding {
  BuildingGraph graph;
  std::size_t records = 0;
  std::vector<std::string> skipped;
  bool torn_tail = false;
};
// Throws as readJournal does.
JournalBuilding rebuildFromJournal(const std::string& path);
// One line per problem the rebuild met (a torn tail, each skipped record), naming `path`.
std::vector<std::string> journalProblems(const std::string& path, const JournalBuilding& journal);
void printJournalProblems(std::ostream& out, const std::string& path, const JournalBuilding& journal);

// A journal's state for `storey journal check`: where its intact prefix ends and why,
// and what that prefix holds. Throws only for a file that is not a journal.
struct JournalCheck {
  common::RecordFileScan scan;
  std::size_t deltas = 0, constraints = 0, retractions = 0;
  std::size_t floor_graphs = 0, nodes = 0;
  std::vector<std::string> robots;
  // Floor-graph updates journalled more than once (same graph and sequence number).
  std::size_t repeated_updates = 0;
  std::vector<std::string> skipped;  // records that cannot be applied, as in JournalBuilding
};
JournalCheck checkJournal(const std::string& path);
void printJournalCheck(std::ostream& out, const std::string& path, const JournalCheck& check);

// Writes the records before a torn tail or damage to a new journal `out` (which must not
// exist); returns the scan of `in`.
common::RecordFileScan salvageJournal(const std::string& in, const std::string& out);

// True for a file that starts like a graph server journal.
bool looksLikeJournal(const std::string& path);

// Encoding, exposed for tests and fuzzing.
std::vector<std::uint8_t> encodeRecord(const JournalRecord& record);
// Decodes one record payload (without framing); throws std::runtime_error on bad bytes.
JournalRecord decodeRecord(const std::uint8_t* data, std::size_t size);

}  // namespace storey::building
