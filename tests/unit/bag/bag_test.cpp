#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>

#include "bag_samples.h"
#include "storey/bag/bag_error.h"
#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "test_support.h"

namespace storey::bag {
namespace {

namespace fs = std::filesystem;
using samples::expectSame;
using samples::randomBytes;
using samples::readAll;
using samples::timeOrdered;
using samples::writeSample;
using samples::Written;

TEST(Bag, WriteThenReadGivesTheSameTopicsAndMessagesInTimeOrder) {
  const std::string folder = test::makeTempDir("bag") + "/run1";
  const auto written = writeSample(folder, 500, 300);
  EXPECT_TRUE(fs::exists(folder + "/run1_0.db3"));
  EXPECT_TRUE(fs::exists(folder + "/metadata.yaml"));

  BagReader reader(folder);
  EXPECT_EQ(reader.schemaVersion(), 3);
  EXPECT_EQ(reader.rosDistro(), "humble");
  samples::expectTheSample(reader, written);
}

TEST(Bag, BagWithoutMetadataYamlIsReadFromItsDatabase) {
  // What a recorder killed before close() leaves behind.
  const std::string folder = test::makeTempDir("bag") + "/killed";
  const auto written = writeSample(folder, 40, 30);
  fs::remove(folder + "/metadata.yaml");
  BagReader reader(folder);
  EXPECT_FALSE(reader.metadata().has_value());
  EXPECT_EQ(reader.messageCount(), 40u);
  expectSame(timeOrdered(written), readAll(reader));
}

TEST(Bag, SummaryCountsAndTimeSpan) {
  const std::string folder = test::makeTempDir("bag") + "/b";
  const auto written = writeSample(folder, 301, 20);
  BagReader reader(folder);
  EXPECT_EQ(reader.messageCount(), 301u);
  const auto& summary = reader.summary();
  ASSERT_EQ(summary.size(), 3u);
  EXPECT_EQ(summary[0].message_count, 101u);
  EXPECT_EQ(summary[1].message_count, 100u);
  EXPECT_EQ(summary[2].message_count, 100u);
  samples::expectTimeSpan(reader, written);
}

TEST(Bag, TopicFilterYieldsOnlyThoseTopics) {
  const std::string folder = test::makeTempDir("bag") + "/f";
  const auto written = writeSample(folder, 90, 10);
  BagReader reader(folder);
  reader.setTopicFilter({"/r1/odom"});
  std::vector<Written> expected;
  for (const auto& w : timeOrdered(written)) {
    if (w.topic == "/r1/odom") expected.push_back(w);
  }
  expectSame(expected, readAll(reader));
  EXPECT_THROW(reader.setTopicFilter({"/nope"}), BagError);
}

TEST(Bag, MetadataYamlHasTheRosbag2Fields) {
  const std::string folder = test::makeTempDir("bag") + "/meta";
  const auto written = writeSample(folder, 30, 10);
  const YAML::Node root = YAML::LoadFile(folder + "/metadata.yaml");
  const YAML::Node info = root["rosbag2_bagfile_information"];
  ASSERT_TRUE(info.IsMap());
  EXPECT_EQ(info["version"].as<int>(), 5);
  EXPECT_EQ(info["storage_identifier"].as<std::string>(), "sqlite3");
  EXPECT_EQ(info["message_count"].as<int>(), 30);
  const auto ordered = timeOrdered(written);
  EXPECT_EQ(info["starting_time"]["nanoseconds_since_epoch"].as<std::int64_t>(),
            ordered.front().stamp);
  EXPECT_EQ(info["duration"]["nanoseconds"].as<std::int64_t>(),
            ordered.back().stamp - ordered.front().stamp);
  ASSERT_EQ(info["topics_with_message_count"].size(), 3u);
  const YAML::Node t0 = info["topics_with_message_count"][0];
  EXPECT_EQ(t0["topic_metadata"]["name"].as<std::string>(), "/r1/scan");
  EXPECT_EQ(t0["topic_metadata"]["type"].as<std::string>(), "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(t0["topic_metadata"]["serialization_format"].as<std::string>(), "cdr");
  EXPECT_EQ(t0["topic_metadata"]["offered_qos_profiles"].as<std::string>(),
            qosProfileYaml(false, false));
  // The QoS string is itself YAML, as ROS 2 parses it.
  const YAML::Node qos = YAML::Load(t0["topic_metadata"]["offered_qos_profiles"].as<std::string>());
  EXPECT_EQ(qos[0]["reliability"].as<int>(), 2);
  EXPECT_EQ(t0["message_count"].as<int>(), 10);
  EXPECT_EQ(info["compression_format"].as<std::string>(), "");
  EXPECT_EQ(info["compression_mode"].as<std::string>(), "");
  EXPECT_EQ(info["relative_file_paths"][0].as<std::string>(), "meta_0.db3");
  EXPECT_EQ(info["files"][0]["path"].as<std::string>(), "meta_0.db3");
  EXPECT_EQ(info["files"][0]["message_count"].as<int>(), 30);

  const BagMetadata parsed = readMetadataFile(folder + "/metadata.yaml");
  EXPECT_EQ(metadataToYaml(parsed), metadataToYaml(metadataFromYaml(metadataToYaml(parsed), "x")));
  EXPECT_EQ(parsed.topics_with_message_count[2].topic.offered_qos_profiles,
            qosProfileYaml(true, true));
}

TEST(Bag, ReadsJazzyMetadataWithItsExtraKeys) {
  // Version 9 as ROS 2 Jazzy writes it: QoS profiles as a YAML list, extra keys.
  const std::string text = R"(rosbag2_bagfile_information:
  version: 9
  storage_identifier: sqlite3
  duration:
    nanoseconds: 2000
  starting_time:
    nanoseconds_since_epoch: 1000
  message_count: 3
  topics_with_message_count:
    - topic_metadata:
        name: /chatter
        type: std_msgs/msg/String
        serialization_format: cdr
        offered_qos_profiles:
          - history: keep_last
            depth: 10
            reliability: reliable
        type_description_hash: RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18
      message_count: 3
  compression_format: ""
  compression_mode: ""
  relative_file_paths:
    - j_0.db3
  files:
    - path: j_0.db3
      starting_time:
        nanoseconds_since_epoch: 1000
      duration:
        nanoseconds: 2000
      message_count: 3
  custom_data: ~
  ros_distro: jazzy
)";
  const BagMetadata m = metadataFromYaml(text, "jazzy/metadata.yaml");
  EXPECT_EQ(m.version, 9);
  EXPECT_EQ(m.message_count, 3u);
  EXPECT_EQ(m.starting_time_ns, 1000);
  ASSERT_EQ(m.topics_with_message_count.size(), 1u);
  EXPECT_EQ(m.topics_with_message_count[0].topic.type, "std_msgs/msg/String");
  const YAML::Node qos = YAML::Load(m.topics_with_message_count[0].topic.offered_qos_profiles);
  EXPECT_EQ(qos[0]["depth"].as<int>(), 10);
  EXPECT_EQ(m.files.at(0).path, "j_0.db3");
  try {
    metadataFromYaml("rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: x\n",
                     "short/metadata.yaml");
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find("short/metadata.yaml: line 2: missing key 'duration'"),
              std::string::npos)
        << e.what();
  }
}

TEST(Bag, EmptyBagHasNoMessages) {
  const std::string folder = test::makeTempDir("bag") + "/empty";
  {
    BagWriter writer(folder);
    writer.createTopic({"/a", "std_msgs/msg/String", "cdr", ""});
  }  // the destructor closes and writes metadata.yaml
  BagReader reader(folder);
  EXPECT_EQ(reader.messageCount(), 0u);
  EXPECT_EQ(reader.startTimeNs(), 0);
  BagMessage m;
  EXPECT_FALSE(reader.next(m));
  ASSERT_EQ(reader.topics().size(), 1u);
}

// A recorder learns the publishers' QoS after it declared the topic: the database and
// metadata.yaml both hold what it set last, one profile per publisher.
TEST(Bag, OfferedQosSetLaterReplacesTheDeclaredOne) {
  const std::string folder = test::makeTempDir("bag") + "/qos";
  {
    BagWriter writer(folder);
    writer.createTopic({"/r/odom", "nav_msgs/msg/Odometry", "cdr", qosProfileYaml(false, false)});
    writer.write("/r/odom", 5, std::vector<std::uint8_t>{0, 1, 0, 0});
    writer.setOfferedQos("/r/odom", qosProfilesYaml({{true, true}, {false, false}}));
    EXPECT_THROW(writer.setOfferedQos("/r/scan", ""), BagError);  // undeclared
  }
  const YAML::Node qos = YAML::Load(readMetadataFile(folder + "/metadata.yaml")
                                        .topics_with_message_count[0]
                                        .topic.offered_qos_profiles);
  ASSERT_EQ(qos.size(), 2u);
  EXPECT_EQ(qos[0]["reliability"].as<int>(), 1);
  EXPECT_EQ(qos[0]["durability"].as<int>(), 1);
  EXPECT_EQ(qos[1]["reliability"].as<int>(), 2);
  BagReader reader(folder);
  EXPECT_EQ(reader.topics()[0].offered_qos_profiles,
            qosProfilesYaml({{true, true}, {false, false}}));
  EXPECT_EQ(qosProfilesYaml({}), "");
}

TEST(Bag, WriterRejectsMisuse) {
  const std::string dir = test::makeTempDir("bag");
  std::ofstream(dir + "/occupied") << "x";
  EXPECT_THROW(BagWriter writer(dir), BagError);  // not empty
  BagWriter writer(dir + "/w");
  writer.createTopic({"/a", "std_msgs/msg/String", "cdr", ""});
  writer.createTopic({"/a", "std_msgs/msg/String", "cdr", ""});  // same again: fine
  EXPECT_THROW(writer.createTopic({"/a", "std_msgs/msg/Int32", "cdr", ""}), BagError);
  EXPECT_THROW(writer.write("/b", 1, {1, 2}), BagError);
  writer.close();
  EXPECT_THROW(writer.write("/a", 1, {1, 2}), BagError);
}

TEST(Bag, MissingFolderAndNonBagFolderNameThePath) {
  const std::string dir = test::makeTempDir("bag");
  try {
    BagReader reader(dir + "/absent");
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/absent"), std::string::npos) << e.what();
  }
  try {
    BagReader reader(dir);  // empty folder
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find("not a bag"), std::string::npos) << e.what();
  }
}

TEST(Bag, GarbageDatabaseIsReportedWithItsName) {
  const std::string dir = test::makeTempDir("bag") + "/garbage";
  fs::create_directories(dir);
  std::mt19937 rng(3);
  const auto junk = randomBytes(rng, 20000);
  std::ofstream(dir + "/garbage_0.db3", std::ios::binary)
      .write(reinterpret_cast<const char*>(junk.data()), junk.size());
  try {
    BagReader reader(dir);
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_EQ(e.file(), dir + "/garbage_0.db3");
    EXPECT_NE(std::string(e.what()).find("garbage_0.db3"), std::string::npos) << e.what();
  }
}

TEST(Bag, SqliteFileWithoutBagTablesIsNotABag) {
  const std::string file = test::makeTempDir("bag") + "/other.db3";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "CREATE TABLE t(x INTEGER)", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  try {
    BagReader reader(file);
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find("other.db3: not a rosbag2 database"), std::string::npos)
        << e.what();
  }
}

TEST(Bag, MalformedMetadataIsReportedWithItsName) {
  const std::string folder = test::makeTempDir("bag") + "/m";
  writeSample(folder, 10, 10);
  std::ofstream(folder + "/metadata.yaml") << "rosbag2_bagfile_information:\n  version: [\n";
  try {
    BagReader reader(folder);
    FAIL() << "no error";
  } catch (const BagError& e) {
    EXPECT_EQ(e.file(), folder + "/metadata.yaml");
  }
  std::ofstream(folder + "/metadata.yaml") << "rosbag2_bagfile_information:\n  version: 5\n";
  EXPECT_THROW(BagReader reader(folder), BagError);  // missing keys
}

TEST(Bag, TruncatedDatabaseThrowsNamingTheFileAndKeepsWhatWasRead) {
  const std::string folder = test::makeTempDir("bag") + "/cut";
  const auto written = timeOrdered(writeSample(folder, 3000, 1500));
  const std::string db = folder + "/cut_0.db3";
  const auto size = fs::file_size(db);
  fs::resize_file(db, size / 2);

  std::vector<Written> read;
  std::string error;
  try {
    BagReader reader(folder);
    BagMessage m;
    while (reader.next(m)) {
      read.push_back({reader.topics()[m.topic_index].name, m.stamp_ns, m.data});
    }
  } catch (const BagError& e) {
    error = e.what();
    EXPECT_EQ(e.file(), db);
  }
  ASSERT_FALSE(error.empty()) << "a truncated database was read without error";
  EXPECT_NE(error.find("cut_0.db3"), std::string::npos) << error;
  // Whatever came out before the error is intact and in order.
  ASSERT_LT(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    ASSERT_EQ(read[i].stamp, written[i].stamp);
    ASSERT_EQ(read[i].data, written[i].data);
  }
}

TEST(Bag, SplitBagIsMergedInTimeOrder) {
  const std::string dir = test::makeTempDir("bag");
  auto a = writeSample(dir + "/a", 100, 50, 1000, 1);
  auto b = writeSample(dir + "/b", 100, 50, 1000 + 5'000'000, 2);  // interleaved stamps
  fs::rename(dir + "/b/b_0.db3", dir + "/a/a_1.db3");
  BagMetadata meta = readMetadataFile(dir + "/a/metadata.yaml");
  meta.relative_file_paths.push_back("a_1.db3");
  writeMetadataFile(dir + "/a/metadata.yaml", meta);

  BagReader reader(dir + "/a");
  EXPECT_EQ(reader.files().size(), 2u);
  EXPECT_EQ(reader.messageCount(), 200u);
  std::vector<Written> all = a;
  all.insert(all.end(), b.begin(), b.end());
  expectSame(timeOrdered(all), readAll(reader));
}

TEST(Bag, ReadsJazzySchema4AndASingleDb3File) {
  const std::string file = test::makeTempDir("bag") + "/jazzy_0.db3";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const char* sql =
      "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
      "INSERT INTO schema VALUES(4, 'jazzy');"
      "CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, "
      "metadata TEXT NOT NULL);"
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
      "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, "
      "type_description_hash TEXT NOT NULL);"
      "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, "
      "encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL, "
      "type_description_hash TEXT NOT NULL);"
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
      "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
      "INSERT INTO topics VALUES(5, '/chatter', 'std_msgs/msg/String', 'cdr', '', 'RIHS01_ab');"
      "INSERT INTO messages(topic_id, timestamp, data) VALUES(5, 20, x'00010000');"
      "INSERT INTO messages(topic_id, timestamp, data) VALUES(5, 10, x'0001000001');"
      "INSERT INTO messages(topic_id, timestamp, data) VALUES(9, 15, x'00');";  // no topic 9
  ASSERT_EQ(sqlite3_exec(db, sql, nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);

  BagReader reader(file);
  EXPECT_EQ(reader.schemaVersion(), 4);
  EXPECT_EQ(reader.rosDistro(), "jazzy");
  ASSERT_EQ(reader.topics().size(), 1u);
  EXPECT_EQ(reader.topics()[0].name, "/chatter");
  BagMessage m;
  ASSERT_TRUE(reader.next(m));
  EXPECT_EQ(m.stamp_ns, 10);
  EXPECT_EQ(m.data, (std::vector<std::uint8_t>{0, 1, 0, 0, 1}));
  ASSERT_TRUE(reader.next(m));
  EXPECT_EQ(m.stamp_ns, 20);
  EXPECT_FALSE(reader.next(m));
}

}  // namespace
}  // namespace storey::bag
