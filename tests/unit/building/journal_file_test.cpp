// The journal's file framing: a torn tail told from damage before the end, `storey
// journal check|salvage` underneath, special files refused by name, and re-delivered
// records recognised (RedeliveryFilter).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "storey/building/journal.h"
#include "storey/building/redelivery.h"
#include "test_support.h"

namespace storey::building {
namespace {

namespace fs = std::filesystem;

FloorGraphDelta nodeDelta(int graph_id, int node, std::uint32_t sequence, double shift = 0.0) {
  FloorGraphDelta d;
  d.robot = "robot_a";
  d.graph_id = graph_id;
  d.sequence = sequence;
  floor::FloorNode n;
  n.id = node;
  n.stamp = 10.0 + node;
  n.pose = geometry::Pose2(node, 0, 0);
  n.scan.ranges.assign(200, 2.0f);
  d.new_nodes.push_back(n);
  if (node > 0) {
    floor::FloorEdge e;
    e.from = node - 1;
    e.to = node;
    e.measurement = geometry::Pose2(1, 0, 0);
    d.new_edges.push_back(e);
  }
  for (int i = 0; i <= node; ++i) d.poses[i] = geometry::Pose2(i + shift, 0, 0);
  return d;
}

// A journal of four records; returns the offset at which each record starts.
std::vector<std::uint64_t> writeFour(const std::string& path) {
  std::vector<std::uint64_t> offsets;
  JournalWriter writer(path, false);
  for (int i = 0; i < 4; ++i) {
    offsets.push_back(fs::file_size(path));
    writer.append(nodeDelta(0, i, static_cast<std::uint32_t>(i)));
  }
  return offsets;
}

void poke(const std::string& path, std::uint64_t offset, const void* bytes, std::size_t n) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(static_cast<std::streamoff>(offset));
  f.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(n));
}

std::string messageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// A middle record's length field made larger than the rest of the file looks like an
// incomplete last record; the records behind it show it is not. The journal is an error
// naming the offset, for readers and the writer alike, and is not cut.
TEST(JournalFile, ALengthDamagedBeforeTheEndIsAnErrorAndTheFileIsKept) {
  const std::string path = test::makeTempDir("journal_length") + "/journal.bin";
  const auto offsets = writeFour(path);
  const auto size = fs::file_size(path);
  const std::uint32_t huge = 5000000;
  poke(path, offsets[1] + 4, &huge, 4);
  const std::string error = messageOf([&] { readJournal(path); });
  EXPECT_NE(error.find("offset " + std::to_string(offsets[1])), std::string::npos) << error;
  EXPECT_NE(error.find("2 intact records follow from offset " + std::to_string(offsets[2])),
            std::string::npos)
      << error;
  EXPECT_THROW(JournalWriter(path, false), common::RecordFileDamaged);
  EXPECT_EQ(fs::file_size(path), size);
  EXPECT_THROW(rebuildFromJournal(path), common::RecordFileDamaged);
}

TEST(JournalFile, AChecksumFailingBeforeTheEndIsAnError) {
  const std::string path = test::makeTempDir("journal_crc") + "/journal.bin";
  const auto offsets = writeFour(path);
  const char bad = 0x55;
  poke(path, offsets[2] + 20, &bad, 1);
  const std::string error = messageOf([&] { JournalWriter(path, false); });
  EXPECT_NE(error.find("offset " + std::to_string(offsets[2]) + " (fails its checksum)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("after 2 intact records"), std::string::npos) << error;
}

// What a crash can leave: part of the last record, or the file extended with zeros
// never written, or a last record whose bytes were not all written. Each is dropped,
// the file cut back, and appending goes on.
TEST(JournalFile, TornTailsAreDroppedAndCutOff) {
  const std::string dir = test::makeTempDir("journal_torn");
  for (int kind = 0; kind < 3; ++kind) {
    const std::string path = dir + "/journal" + std::to_string(kind) + ".bin";
    const auto offsets = writeFour(path);
    const auto size = fs::file_size(path);
    if (kind == 0) fs::resize_file(path, size - 9);
    if (kind == 1) fs::resize_file(path, size + 300);  // zeros
    if (kind == 2) {
      const std::vector<char> zeros(40, 0);
      poke(path, size - 50, zeros.data(), zeros.size());
    }
    const JournalReadResult read = readJournal(path);
    EXPECT_TRUE(read.torn_tail) << kind;
    EXPECT_EQ(read.records.size(), kind == 1 ? 4u : 3u) << kind;
    {
      JournalWriter writer(path, false);
      EXPECT_TRUE(writer.hadTornTail());
      writer.append(nodeDelta(1, 0, 0));
    }
    const JournalReadResult again = readJournal(path);
    EXPECT_FALSE(again.torn_tail) << kind;
    EXPECT_EQ(again.records.size(), kind == 1 ? 5u : 4u) << kind;
    (void)offsets;
  }
}

TEST(JournalFile, CheckSaysWhereTheDamageIsAndSalvageKeepsWhatPrecedesIt) {
  const std::string dir = test::makeTempDir("journal_salvage");
  const std::string path = dir + "/journal.bin";
  const auto offsets = writeFour(path);
  EXPECT_EQ(checkJournal(path).scan.end, common::RecordFileEnd::kIntact);
  EXPECT_EQ(checkJournal(path).nodes, 4u);
  const std::uint32_t huge = 5000000;
  poke(path, offsets[2] + 4, &huge, 4);
  const JournalCheck check = checkJournal(path);
  EXPECT_EQ(check.scan.end, common::RecordFileEnd::kDamaged);
  EXPECT_EQ(check.scan.records, 2u);
  EXPECT_EQ(check.scan.valid_bytes, offsets[2]);
  EXPECT_EQ(check.scan.intact_after, 1u);
  EXPECT_EQ(check.nodes, 2u);
  const common::RecordFileScan salvaged = salvageJournal(path, dir + "/salvaged.bin");
  EXPECT_EQ(salvaged.records, 2u);
  EXPECT_EQ(fs::file_size(dir + "/salvaged.bin"), offsets[2]);
  JournalWriter resumed(dir + "/salvaged.bin", false);
  EXPECT_EQ(resumed.existing().size(), 2u);
  EXPECT_FALSE(resumed.hadTornTail());
  EXPECT_NE(messageOf([&] { salvageJournal(path, dir + "/salvaged.bin"); }).find("already exists"),
            std::string::npos);
}

TEST(JournalFile, RecordsJournalledTwiceAreCounted) {
  const std::string path = test::makeTempDir("journal_twice") + "/journal.bin";
  {
    JournalWriter writer(path, false);
    writer.append(nodeDelta(0, 0, 0));
    writer.append(nodeDelta(0, 1, 1));
    writer.append(nodeDelta(0, 0, 0, 0.5));
  }
  EXPECT_EQ(checkJournal(path).repeated_updates, 1u);
}

// A directory, a device that never ends and a FIFO that would block: refused by name
// before anything is read.
TEST(JournalFile, SpecialFilesAreRefusedByName) {
  const std::string dir = test::makeTempDir("journal_special");
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::pair<std::string, std::string> cases[] = {
      {dir, "a directory, not a journal"},
      {"/dev/zero", "a character device, not a journal"},
      {fifo, "a FIFO, not a journal"},
      {dir + "/missing", "cannot open the journal: no such file"}};
  for (const auto& c : cases) {
    const std::string error = messageOf([&] { readJournal(c.first); });
    EXPECT_NE(error.find(c.first + ": " + c.second), std::string::npos) << error;
  }
  for (const auto& c : {cases[0], cases[1], cases[2]}) {
    const std::string error = messageOf([&] { JournalWriter(c.first, false); });
    EXPECT_NE(error.find(c.first + ": " + c.second), std::string::npos) << error;
  }
}

TEST(RedeliveryFilter, OldUpdatesAndRetractedConstraintsAreRecognised) {
  BuildingGraph building;
  RedeliveryFilter filter;
  auto accept = [&](const JournalRecord& r) {
    EXPECT_FALSE(filter.isRedelivery(building, r));
    filter.noteAccepted(building, r);
    applyRecord(building, r);
  };
  accept(nodeDelta(0, 0, 0));
  accept(nodeDelta(0, 1, 1, 0.2));
  accept(nodeDelta(0, 2, 2, 0.4));
  // Sent again: older poses, nothing new.
  EXPECT_TRUE(filter.isRedelivery(building, nodeDelta(0, 0, 0)));
  EXPECT_TRUE(filter.isRedelivery(building, nodeDelta(0, 1, 1, 0.2)));
  // An old number with a node the graph lacks (or a node with another stamp) is not.
  EXPECT_FALSE(filter.isRedelivery(building, nodeDelta(0, 3, 1)));
  FloorGraphDelta other_stamp = nodeDelta(0, 1, 1);
  other_stamp.new_nodes[0].stamp += 1.0;
  EXPECT_FALSE(filter.isRedelivery(building, other_stamp));
  EXPECT_FALSE(filter.isRedelivery(building, nodeDelta(0, 3, 3)));
  EXPECT_FALSE(filter.isRedelivery(building, nodeDelta(1, 0, 0)));
  accept(nodeDelta(1, 0, 0));
  InterGraphConstraint c;
  c.id = 4;
  c.graph_from = 0;
  c.node_from = 1;
  c.graph_to = 1;
  c.node_to = 0;
  c.relative = geometry::Pose2(0.5, 0, 0);
  c.information = Eigen::Matrix3d::Identity() * 10;
  accept(c);
  ConstraintRetraction r;
  r.graph_from = 0;
  r.node_from = 1;
  r.graph_to = 1;
  r.node_to = 0;
  accept(r);
  EXPECT_TRUE(filter.isRedelivery(building, c));
  InterGraphConstraint proposed_again = c;
  proposed_again.relative = geometry::Pose2(0.6, 0, 0);
  EXPECT_FALSE(filter.isRedelivery(building, proposed_again));
}

}  // namespace
}  // namespace storey::building
