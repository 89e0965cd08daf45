// Bags with mcap storage: what BagWriter writes reads back, and files laid out as other
// writers lay them out (messages outside chunks, uncompressed and lz4 chunks, out-of-order
// stamps) read too.
#include <lz4frame.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>

#include "bag_samples.h"
#include "storey/bag/bag_error.h"
#include "storey/bag/mcap_file.h"
#include "test_support.h"

namespace storey::bag {
namespace {

namespace fs = std::filesystem;
using samples::expectSame;
using samples::readAll;
using samples::timeOrdered;
using samples::Written;

std::vector<Written> writeMcap(const std::string& folder, int count, std::size_t max_size) {
  return samples::writeSample(folder, count, max_size, 1'700'000'000'000'000'000, 7, kStorageMcap);
}

std::vector<std::uint8_t> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::uint64_t le(const std::vector<std::uint8_t>& b, std::size_t at, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}

// 3000 messages of up to 1500 bytes: several 1 MiB chunks.
TEST(McapBag, WriteThenReadGivesTheSameTopicsAndMessagesInTimeOrder) {
  const std::string folder = test::makeTempDir("mcap") + "/run1";
  const auto written = writeMcap(folder, 3000, 1500);
  EXPECT_TRUE(fs::exists(folder + "/run1_0.mcap"));
  EXPECT_FALSE(fs::exists(folder + "/run1_0.db3"));
  const BagMetadata meta = readMetadataFile(folder + "/metadata.yaml");
  EXPECT_EQ(meta.storage_identifier, "mcap");
  EXPECT_EQ(meta.relative_file_paths, std::vector<std::string>{"run1_0.mcap"});
  EXPECT_EQ(meta.message_count, 3000u);

  BagReader reader(folder);
  EXPECT_EQ(reader.storage(), "mcap");
  samples::expectTheSample(reader, written);

  EXPECT_EQ(reader.messageCount(), 3000u);
  EXPECT_EQ(reader.summary()[0].message_count, 1000u);
  samples::expectTimeSpan(reader, written);

  reader.setTopicFilter({"/r1/odom"});
  std::vector<Written> odom;
  for (const auto& w : timeOrdered(written))
    if (w.topic == "/r1/odom") odom.push_back(w);
  expectSame(odom, readAll(reader));

  // The same file read alone, and the folder without metadata.yaml.
  EXPECT_EQ(BagReader(folder + "/run1_0.mcap").messageCount(), 3000u);
  fs::remove(folder + "/metadata.yaml");
  EXPECT_EQ(BagReader(folder).messageCount(), 3000u);
}

// The layout the MCAP specification asks for: magic at both ends, the footer pointing at
// the summary (schemas, channels, statistics, chunk indexes) and its offset records, each
// chunk index pointing at a chunk record.
TEST(McapBag, WrittenFileHasTheSummaryAndIndexes) {
  const std::string folder = test::makeTempDir("mcap") + "/s";
  writeMcap(folder, 3000, 1500);
  const auto b = fileBytes(folder + "/s_0.mcap");
  ASSERT_GT(b.size(), 16u + 29u);
  const std::vector<std::uint8_t> magic{0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  EXPECT_TRUE(std::equal(magic.begin(), magic.end(), b.begin()));
  EXPECT_TRUE(std::equal(magic.begin(), magic.end(), b.end() - 8));
  const std::size_t footer = b.size() - 8 - 29;
  ASSERT_EQ(b[footer], 0x02);
  const std::uint64_t summary = le(b, footer + 9, 8), offsets = le(b, footer + 17, 8);
  ASSERT_GT(summary, 0u);
  ASSERT_GT(offsets, summary);
  std::map<int, int> ops;
  int chunks_indexed = 0;
  for (std::size_t at = summary; at < offsets;) {
    const int op = b[at];
    ++ops[op];
    if (op == 0x08) {  // chunk index: its chunk_start_offset holds a chunk record
      const std::uint64_t chunk = le(b, at + 9 + 16, 8);
      EXPECT_EQ(b[chunk], 0x06);
      ++chunks_indexed;
    }
    at += 9 + le(b, at + 1, 8);
  }
  EXPECT_EQ(ops[0x03], 3);       // a schema per type
  EXPECT_EQ(ops[0x04], 3);       // a channel per topic
  EXPECT_EQ(ops[0x0b], 1);       // statistics
  EXPECT_GE(chunks_indexed, 3);  // 3000 x ~750 B in 1 MiB chunks
  int groups = 0;
  for (std::size_t at = offsets; at < footer; at += 9 + le(b, at + 1, 8)) {
    EXPECT_EQ(b[at], 0x0e);
    ++groups;
  }
  EXPECT_EQ(groups, 4);
}

// The schemas carry the ROS 2 IDL of storey's types with the types they include, as
// ros2idl readers (Foxglove) decode CDR with.
TEST(McapBag, SchemasCarryTheTypesIdl) {
  const std::string idl = detail::ros2IdlSchema("sensor_msgs/msg/LaserScan");
  EXPECT_NE(idl.find("struct LaserScan"), std::string::npos);
  EXPECT_NE(idl.find("\n" + std::string(80, '=') + "\nIDL: std_msgs/msg/Header\n"),
            std::string::npos);
  EXPECT_NE(idl.find("IDL: builtin_interfaces/msg/Time\n"), std::string::npos);
  EXPECT_EQ(idl.find("IDL: sensor_msgs/msg/LaserScan"), std::string::npos);
  EXPECT_EQ(idl.find("#ifndef"), std::string::npos);  // ros2idl readers take only #include
  EXPECT_EQ(idl.find("#endif"), std::string::npos);
  EXPECT_EQ(detail::ros2IdlSchema("example_msgs/msg/Unknown"), "");
  const std::string folder = test::makeTempDir("mcap") + "/idl";
  writeMcap(folder, 10, 10);
  const auto b = fileBytes(folder + "/idl_0.mcap");
  const std::string text(b.begin(), b.end());
  EXPECT_NE(text.find("ros2idl"), std::string::npos);
}

// A topic's channel record holds the QoS set before its first message; metadata.yaml the
// last set.
TEST(McapBag, OfferedQosIsTheOneKnownAtTheFirstMessage) {
  const std::string folder = test::makeTempDir("mcap") + "/qos";
  {
    BagWriter writer(folder, BagWriterOptions{64, "humble", kStorageMcap});
    writer.createTopic({"/r/odom", "nav_msgs/msg/Odometry", "cdr", qosProfileYaml(false, false)});
    writer.setOfferedQos("/r/odom", qosProfilesYaml({{true, false}}));
    writer.write("/r/odom", 5, std::vector<std::uint8_t>{0, 1, 0, 0});
    writer.setOfferedQos("/r/odom", qosProfilesYaml({{true, false}, {false, false}}));
  }
  EXPECT_EQ(BagReader(folder + "/qos_0.mcap").topics()[0].offered_qos_profiles,
            qosProfilesYaml({{true, false}}));
  EXPECT_EQ(readMetadataFile(folder + "/metadata.yaml")
                .topics_with_message_count[0]
                .topic.offered_qos_profiles,
            qosProfilesYaml({{true, false}, {false, false}}));
}

// A recording cut short: its complete chunks are read, then an error naming the file.
TEST(McapBag, TruncatedFileGivesItsCompleteMessagesThenNamesTheFile) {
  const std::string folder = test::makeTempDir("mcap") + "/cut";
  const auto written = writeMcap(folder, 3000, 1500);
  const std::string file = folder + "/cut_0.mcap";
  fs::resize_file(file, fs::file_size(file) / 2);
  std::vector<Written> read;
  std::string error;
  try {
    BagReader reader(folder);
    BagMessage m;
    while (reader.next(m))
      read.push_back({reader.topics()[m.topic_index].name, m.stamp_ns, m.data});
  } catch (const BagError& e) {
    error = e.what();
    EXPECT_EQ(e.file(), file);
  }
  EXPECT_NE(error.find("cut short"), std::string::npos) << error;
  EXPECT_GT(read.size(), 500u);
  EXPECT_LT(read.size(), written.size());
  for (std::size_t i = 1; i < read.size(); ++i) ASSERT_LE(read[i - 1].stamp, read[i].stamp);
  for (const Written& r : read)
    ASSERT_TRUE(std::any_of(written.begin(), written.end(), [&](const Written& w) {
      return w.stamp == r.stamp && w.topic == r.topic && w.data == r.data;
    }));
}

// A damaged chunk and a file that is no MCAP are errors naming the file.
TEST(McapBag, DamagedOrForeignFilesAreNamed) {
  const std::string dir = test::makeTempDir("mcap");
  writeMcap(dir + "/d", 300, 1500);
  const std::string file = dir + "/d/d_0.mcap";
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(file) / 4));
    const char junk[64] = {};
    f.write(junk, sizeof junk);
  }
  try {
    BagReader reader(dir + "/d");
    FAIL() << "a damaged chunk was read";
  } catch (const BagError& e) {
    EXPECT_EQ(e.file(), file) << e.what();
  }
  std::ofstream(dir + "/other.mcap") << "not an mcap file at all";
  try {
    BagReader reader(dir + "/other.mcap");
    FAIL() << "a text file was read as MCAP";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find("not an MCAP file"), std::string::npos) << e.what();
  }
}

// Records as the specification lays them out, for files storey's writer does not make.
struct Records {
  std::vector<std::uint8_t> b;
  Records& u(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  Records& s(const std::string& text) {
    u(text.size(), 4);
    b.insert(b.end(), text.begin(), text.end());
    return *this;
  }
  Records& add(std::uint8_t op, const Records& content) {
    u(op, 1).u(content.b.size(), 8);
    b.insert(b.end(), content.b.begin(), content.b.end());
    return *this;
  }
  Records& message(int channel, std::uint64_t stamp, std::uint8_t value) {
    return add(0x05, Records().u(channel, 2).u(0, 4).u(stamp, 8).u(stamp, 8).u(value, 1));
  }
};

Records chunk(const Records& inner, const std::string& compression, std::uint64_t start,
              std::uint64_t end) {
  std::vector<std::uint8_t> data = inner.b;
  if (compression == "lz4") {
    data.resize(LZ4F_compressFrameBound(inner.b.size(), nullptr));
    data.resize(
        LZ4F_compressFrame(data.data(), data.size(), inner.b.data(), inner.b.size(), nullptr));
  }
  Records c;
  c.u(start, 8).u(end, 8).u(inner.b.size(), 8).u(0, 4).s(compression).u(data.size(), 8);
  c.b.insert(c.b.end(), data.begin(), data.end());
  return Records().add(0x06, c);
}

// No summary, no indexes: a schema and channel outside chunks with two messages after them,
// a second channel inside an lz4 chunk, an uncompressed chunk; stamps out of order
// across them, ties kept in file order.
TEST(McapBag, ReadsMessagesOutsideChunksAndLz4AndUncompressedChunks) {
  Records file;
  const std::vector<std::uint8_t> magic{0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
  file.b = magic;
  file.add(0x01, Records().s("ros2").s("elsewhere"));
  file.add(0x03, Records().u(1, 2).s("std_msgs/msg/Int32").s("ros2msg").s("int32 data"));
  const Records qos = Records().s("offered_qos_profiles").s("- reliability: 1");
  Records channel = Records().u(1, 2).u(1, 2).s("/a").s("cdr").u(qos.b.size(), 4);
  channel.b.insert(channel.b.end(), qos.b.begin(), qos.b.end());
  file.add(0x04, channel);
  file.message(1, 30, 1).message(1, 10, 2);
  Records inner;
  inner.add(0x03, Records().u(2, 2).s("std_msgs/msg/String").s("").s(""));
  inner.add(0x04, Records().u(2, 2).u(2, 2).s("/b").s("cdr").u(0, 4));
  inner.message(2, 20, 3).message(2, 10, 4).message(1, 40, 5);
  Records plain;
  plain.message(2, 5, 6).message(1, 10, 7);
  const Records lz4 = chunk(inner, "lz4", 10, 40), none = chunk(plain, "", 5, 10);
  file.b.insert(file.b.end(), lz4.b.begin(), lz4.b.end());
  file.b.insert(file.b.end(), none.b.begin(), none.b.end());
  file.add(0x0f, Records().u(0, 4)).add(0x02, Records().u(0, 8).u(0, 8).u(0, 4));
  file.b.insert(file.b.end(), magic.begin(), magic.end());
  const std::string path = test::makeTempDir("mcap") + "/foreign.mcap";
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(file.b.data()),
             static_cast<std::streamsize>(file.b.size()));

  BagReader reader(path);
  ASSERT_EQ(reader.topics().size(), 2u);
  EXPECT_EQ(reader.topics()[0].type, "std_msgs/msg/Int32");
  EXPECT_EQ(reader.topics()[0].offered_qos_profiles, "- reliability: 1");
  EXPECT_EQ(reader.topics()[1].type, "std_msgs/msg/String");
  const std::vector<std::pair<std::int64_t, int>> expected{{5, 6},  {10, 2}, {10, 4}, {10, 7},
                                                           {20, 3}, {30, 1}, {40, 5}};
  BagMessage m;
  for (const auto& [stamp, value] : expected) {
    ASSERT_TRUE(reader.next(m));
    EXPECT_EQ(m.stamp_ns, stamp);
    ASSERT_EQ(m.data.size(), 1u);
    EXPECT_EQ(m.data[0], value);
  }
  EXPECT_FALSE(reader.next(m));
  EXPECT_EQ(reader.summary()[1].message_count, 3u);
}

}  // namespace
}  // namespace storey::bag
