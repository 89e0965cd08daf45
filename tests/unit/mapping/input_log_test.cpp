#include "storey/mapping/input_log.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

#include "test_support.h"

namespace storey::mapping {
namespace {

sensor::LaserScan scanAt(double stamp) {
  sensor::LaserScan s;
  s.stamp = stamp;
  s.angle_min = -1.5;
  s.angle_increment = 0.01;
  s.range_min = 0.1;
  s.range_max = 30.0;
  s.sensor_offset = geometry::Pose2(0.2, 0.0, 0.01);
  s.ranges = {1.0f, 2.5f, std::numeric_limits<float>::infinity(), 3.25f};
  return s;
}

TEST(InputLog, ReplaysWhatWasAppendedInOrder) {
  const std::string path = storey::test::makeTempDir("input_log") + "/mapper.log";
  {
    InputLog log(path, [](const LoggedInput&) { FAIL() << "a new log has no inputs"; });
    log.appendScan(scanAt(1.0), geometry::Pose2(1.0, 2.0, 0.3));
    floor::FloorEvent e;
    e.type = floor::FloorEventType::kTransitEnded;
    e.stamp = 1.5;
    e.decided_at = 2.0;
    e.floor_id = 2;
    e.floor_height = 7.0;
    log.appendFloorEvent(e);
    log.appendScan(scanAt(3.0), geometry::Pose2(1.5, 2.0, 0.3));
  }
  std::vector<LoggedInput> back;
  InputLog reopened(path, [&](const LoggedInput& in) { back.push_back(in); });
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(reopened.existingInputs(), 3u);
  EXPECT_DOUBLE_EQ(reopened.lastScanStamp(), 3.0);
  EXPECT_DOUBLE_EQ(reopened.lastEventDecidedAt(), 2.0);
  EXPECT_TRUE(back[0].is_scan);
  EXPECT_EQ(back[0].scan.ranges, scanAt(1.0).ranges);
  EXPECT_DOUBLE_EQ(back[0].scan.sensor_offset.theta(), 0.01);
  EXPECT_DOUBLE_EQ(back[0].odometry.y(), 2.0);
  EXPECT_FALSE(back[1].is_scan);
  EXPECT_EQ(back[1].event.type, floor::FloorEventType::kTransitEnded);
  EXPECT_EQ(back[1].event.floor_id, 2);
  EXPECT_DOUBLE_EQ(back[1].event.floor_height, 7.0);
  EXPECT_DOUBLE_EQ(back[1].event.decided_at, 2.0);
  EXPECT_DOUBLE_EQ(back[2].scan.stamp, 3.0);
}

TEST(InputLog, ATornLastRecordIsDroppedAndCutOff) {
  const std::string path = storey::test::makeTempDir("input_log_torn") + "/mapper.log";
  {
    InputLog log(path, [](const LoggedInput&) {});
    log.appendScan(scanAt(1.0), geometry::Pose2());
    log.appendScan(scanAt(2.0), geometry::Pose2());
  }
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 7);  // killed mid-write
  int n = 0;
  {
    InputLog log(path, [&](const LoggedInput&) { ++n; });
    EXPECT_EQ(n, 1);
    log.appendScan(scanAt(5.0), geometry::Pose2());  // appended after the intact prefix
  }
  std::vector<double> stamps;
  InputLog again(path, [&](const LoggedInput& in) { stamps.push_back(in.scan.stamp); });
  EXPECT_EQ(stamps, (std::vector<double>{1.0, 5.0}));
}

TEST(InputLog, AnotherFileIsRefusedByName) {
  const std::string path = storey::test::makeTempDir("input_log_other") + "/journal.bin";
  std::ofstream(path) << "STOREYJ1 not an input log";
  try {
    InputLog log(path, [](const LoggedInput&) {});
    FAIL() << "opened a graph server journal as an input log";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a storey input log"), std::string::npos) << e.what();
  }
}

TEST(InputLog, BadBytesAreAnErrorNotACrash) {
  const std::vector<std::uint8_t> bad = {2, 9, 0, 0};
  EXPECT_THROW(decodeLoggedInput(bad.data(), bad.size()), std::runtime_error);
  LoggedInput in;
  in.scan = scanAt(1.0);
  std::vector<std::uint8_t> bytes = encodeLoggedInput(in);
  EXPECT_THROW(decodeLoggedInput(bytes.data(), bytes.size() - 1), std::runtime_error);
  bytes.push_back(0);
  EXPECT_THROW(decodeLoggedInput(bytes.data(), bytes.size()), std::runtime_error);
}

TEST(InputLog, AnUnsureArrivalKeepsItsCandidatesAndOldRecordsStillRead) {
  LoggedInput in;
  in.is_scan = false;
  in.event.type = floor::FloorEventType::kTransitEnded;
  in.event.stamp = 10.0;
  in.event.decided_at = 12.0;
  in.event.floor_id = 1;
  in.event.floor_height = 3.0;
  in.event.candidate_floors = {1, 0};
  in.event.new_floor_id = 2;
  in.event.new_floor_height = 3.2;
  const std::vector<std::uint8_t> bytes = encodeLoggedInput(in);
  const LoggedInput back = decodeLoggedInput(bytes.data(), bytes.size());
  EXPECT_EQ(back.event.candidate_floors, (std::vector<int>{1, 0}));
  EXPECT_EQ(back.event.new_floor_id, 2);
  EXPECT_DOUBLE_EQ(back.event.new_floor_height, 3.2);
  // A record written before events carried candidates (type 2): type, stamp, decided_at,
  // floor id, floor height.
  common::ByteEncoder old;
  old.put<std::uint8_t>(2);
  old.put<std::uint8_t>(1);
  old.put(10.0);
  old.put(12.0);
  old.put<std::int32_t>(1);
  old.put(3.0);
  const LoggedInput legacy = decodeLoggedInput(old.bytes.data(), old.bytes.size());
  EXPECT_EQ(legacy.event.floor_id, 1);
  EXPECT_FALSE(legacy.event.identityUnsure());
  // AwaitingIdentity is logged too (the mapper decides on it); Progress never is.
  in.event.type = floor::FloorEventType::kAwaitingIdentity;
  const std::vector<std::uint8_t> waiting = encodeLoggedInput(in);
  EXPECT_EQ(decodeLoggedInput(waiting.data(), waiting.size()).event.type,
            floor::FloorEventType::kAwaitingIdentity);
  in.event.type = floor::FloorEventType::kProgress;
  const std::vector<std::uint8_t> progress = encodeLoggedInput(in);
  EXPECT_THROW(decodeLoggedInput(progress.data(), progress.size()), std::runtime_error);
}

}  // namespace
}  // namespace storey::mapping
