#include "storey/io/carmen.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "test_support.h"

namespace storey::io {
namespace {

std::string writeText(const std::string& name, const std::string& text) {
  const std::string path = test::makeTempDir("storey_io") + "/" + name;
  std::ofstream out(path, std::ios::binary);
  out << text;
  return path;
}

std::string writeGzip(const std::string& name, const std::string& text) {
  const std::string path = test::makeTempDir("storey_io") + "/" + name;
  gzFile file = gzopen(path.c_str(), "wb");
  if (!file) throw std::runtime_error("cannot create " + path);
  gzwrite(file, text.data(), static_cast<unsigned>(text.size()));
  gzclose(file);
  return path;
}

std::string flaserLine(int n, double first_range, const std::string& pose_and_stamp) {
  std::ostringstream out;
  out << "FLASER " << n;
  for (int i = 0; i < n; ++i) out << " " << first_range + 0.01 * i;
  out << " " << pose_and_stamp;
  return out.str();
}

std::vector<CarmenRecord> readAll(const std::string& path, const CarmenReaderOptions& options,
                                  CarmenStats* stats = nullptr) {
  CarmenReader reader(path, options);
  std::vector<CarmenRecord> records;
  CarmenRecord record;
  while (reader.next(&record)) records.push_back(record);
  if (stats) *stats = reader.stats();
  return records;
}

CarmenReaderOptions lenient() {
  CarmenReaderOptions o;
  o.strict = false;
  return o;
}

TEST(CarmenReader, FlaserWithDefaultAnglesAndBothPoses) {
  const std::string path =
      writeText("a.log", "# a comment\n\n" +
                             flaserLine(180, 1.0, "1 2 0.5 1.1 2.1 0.6 12.5 host7 12.75") + "\n");
  CarmenStats stats;
  const auto records = readAll(path, {}, &stats);
  ASSERT_EQ(records.size(), 1u);
  const CarmenRecord& r = records[0];
  EXPECT_EQ(r.kind, CarmenRecordKind::kLaser);
  EXPECT_EQ(r.type, "FLASER");
  EXPECT_EQ(r.line, 3u);
  EXPECT_EQ(r.host, "host7");
  EXPECT_DOUBLE_EQ(r.logger_stamp, 12.75);
  const sensor::LaserScan& scan = r.laser.scan;
  ASSERT_EQ(scan.ranges.size(), 180u);
  EXPECT_FLOAT_EQ(scan.ranges[0], 1.0f);
  EXPECT_FLOAT_EQ(scan.ranges[179], 2.79f);
  EXPECT_DOUBLE_EQ(scan.stamp, 12.5);
  // 180 beams over 180 degrees: 1 degree apart from -90.
  EXPECT_NEAR(scan.angle_min, -M_PI / 2, 1e-12);
  EXPECT_NEAR(scan.angle_increment, M_PI / 180, 1e-12);
  EXPECT_DOUBLE_EQ(scan.range_max, 80.0);
  EXPECT_TRUE(scan.validate().empty()) << scan.validate();
  EXPECT_EQ(r.laser.laser_id, 1);
  EXPECT_TRUE(r.laser.has_pose);
  EXPECT_DOUBLE_EQ(r.laser.laser_pose.x(), 1.0);
  EXPECT_DOUBLE_EQ(r.laser.laser_pose.theta(), 0.5);
  EXPECT_DOUBLE_EQ(r.laser.odom_pose.y(), 2.1);
  EXPECT_DOUBLE_EQ(r.laser.odom_pose.theta(), 0.6);
  EXPECT_EQ(stats.lines, 3u);
  EXPECT_EQ(stats.comments, 1u);
  EXPECT_EQ(stats.blank, 1u);
  EXPECT_EQ(stats.recordCount("FLASER"), 1u);
}

TEST(CarmenReader, OddBeamCountSpansTheFieldOfViewInclusive) {
  const std::string path = writeText("a.log", flaserLine(361, 1.0, "0 0 0 0 0 0 1") + "\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 1u);
  const auto& scan = records[0].laser.scan;
  EXPECT_NEAR(scan.angle(0), -M_PI / 2, 1e-12);
  EXPECT_NEAR(scan.angle(360), M_PI / 2, 1e-12);
  EXPECT_TRUE(records[0].host.empty());  // the short form without host and logger stamp
}

TEST(CarmenReader, ParamsSetFieldOfViewRangeLimitAndLaserOffset) {
  const std::string path =
      writeText("a.log",
                "PARAM laser_front_laser_fov 100 1.0 host 1.0\n"  // degrees in some logs
                "PARAM robot_front_laser_max 50\n"
                "PARAM robot_frontlaser_offset 0.25 1.0 host 1.0\n"
                "PARAM robot_rearlaser_offset 0.1\n"
                "PARAM laser_rear_laser_fov 3.14159265358979\n" +
                    flaserLine(101, 1.0, "1 0 1.5707963267948966 0 0 0 1 h 1") + "\n" +
                    "RLASER 4 1 1 1 1 0 0 0 0 0 0 2 h 2\n");
  CarmenReader reader(path);
  CarmenRecord r;
  std::vector<CarmenRecord> lasers;
  std::size_t params = 0;
  while (reader.next(&r)) {
    if (r.kind == CarmenRecordKind::kParam) ++params;
    if (r.kind == CarmenRecordKind::kLaser) lasers.push_back(r);
  }
  EXPECT_EQ(params, 5u);
  EXPECT_EQ(reader.params().at("robot_front_laser_max"), "50");
  EXPECT_DOUBLE_EQ(*reader.paramDouble("robot_frontlaser_offset"), 0.25);
  EXPECT_FALSE(reader.paramDouble("missing").has_value());
  ASSERT_EQ(lasers.size(), 2u);
  const auto& front = lasers[0].laser;
  EXPECT_NEAR(front.scan.angle(0), -50 * M_PI / 180, 1e-12);
  EXPECT_NEAR(front.scan.angle(100), 50 * M_PI / 180, 1e-12);
  EXPECT_DOUBLE_EQ(front.scan.range_max, 50.0);
  EXPECT_DOUBLE_EQ(front.scan.sensor_offset.x(), 0.25);
  // The robot sits 0.25 m behind the laser, which faces +y.
  EXPECT_NEAR(front.robotPose().x(), 1.0, 1e-12);
  EXPECT_NEAR(front.robotPose().y(), -0.25, 1e-12);
  const auto& rear = lasers[1].laser;
  EXPECT_EQ(rear.laser_id, 2);
  EXPECT_EQ(lasers[1].type, "RLASER");
  EXPECT_NEAR(std::abs(rear.scan.sensor_offset.theta()), M_PI, 1e-12);
  EXPECT_DOUBLE_EQ(rear.scan.sensor_offset.x(), -0.1);
  EXPECT_NEAR(rear.scan.angle_increment, M_PI / 4, 1e-9);  // 4 beams (even) over pi
  EXPECT_DOUBLE_EQ(rear.scan.range_max, 80.0);             // no robot_rear_laser_max: the default
}

TEST(CarmenReader, NanAndInfiniteRangesAreKeptAsNoReturn) {
  const std::string path = writeText(
      "a.log", "FLASER 4 1.5 nan inf 81.91 0 0 0 0 0 0 3 h 3\nFLASER 2 NaN -inf 0 0 0 0 0 0 4\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 2u);
  const auto& scan = records[0].laser.scan;
  EXPECT_TRUE(scan.isReturn(0));
  EXPECT_TRUE(std::isnan(scan.ranges[1]));
  EXPECT_TRUE(std::isinf(scan.ranges[2]));
  EXPECT_FALSE(scan.isReturn(1));
  EXPECT_FALSE(scan.isReturn(2));
  EXPECT_FALSE(scan.isReturn(3));  // beyond the 80 m default range limit
  EXPECT_EQ(scan.countReturns(), 1u);
  EXPECT_TRUE(std::isnan(records[1].laser.scan.ranges[0]));
  EXPECT_TRUE(std::isinf(records[1].laser.scan.ranges[1]));
}

TEST(CarmenReader, RobotLaserCarriesItsOwnAnglesPosesAndRemissions) {
  // type start fov res max accuracy mode n ranges m remissions laser pose robot pose
  // tv rv fsd ssd turn stamp host logger
  const std::string path =
      writeText("a.log",
                "ROBOTLASER1 0 -1.0 2.0 0.5 30 0.01 0 5 1 2 3 4 5 2 0.5 0.7 "
                "1.2 2.0 0.0 1.0 2.0 0.0 0.1 0.2 0.3 0.4 0.5 100.5 robot 100.6\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 1u);
  const CarmenLaser& laser = records[0].laser;
  EXPECT_EQ(records[0].type, "ROBOTLASER1");
  EXPECT_EQ(laser.laser_id, 1);
  EXPECT_DOUBLE_EQ(laser.scan.angle_min, -1.0);
  EXPECT_DOUBLE_EQ(laser.scan.angle_increment, 0.5);
  EXPECT_DOUBLE_EQ(laser.scan.range_max, 30.0);
  ASSERT_EQ(laser.scan.ranges.size(), 5u);
  EXPECT_FLOAT_EQ(laser.scan.ranges[4], 5.0f);
  ASSERT_EQ(laser.remissions.size(), 2u);
  EXPECT_FLOAT_EQ(laser.remissions[1], 0.7f);
  EXPECT_DOUBLE_EQ(laser.scan.stamp, 100.5);
  EXPECT_EQ(records[0].host, "robot");
  // The laser sits 0.2 m ahead of the robot: the offset is exact.
  EXPECT_NEAR(laser.scan.sensor_offset.x(), 0.2, 1e-12);
  EXPECT_NEAR(laser.scan.sensor_offset.y(), 0.0, 1e-12);
  EXPECT_NEAR(laser.robotPose().x(), 1.0, 1e-12);
  EXPECT_NEAR(laser.robotPose().y(), 2.0, 1e-12);
}

TEST(CarmenReader, RawLaserHasNoPose) {
  const std::string path =
      writeText("a.log", "RAWLASER3 0 -1.5 3.0 1.0 8 0.01 0 4 1 2 3 4 0 7.5 h 7.5\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 1u);
  EXPECT_EQ(records[0].laser.laser_id, 3);
  EXPECT_FALSE(records[0].laser.has_pose);
  EXPECT_DOUBLE_EQ(records[0].laser.scan.angle(3), 1.5);
  // readCarmenLasers keeps only lasers with a pose.
  EXPECT_TRUE(readCarmenLasers(path).empty());
}

TEST(CarmenReader, OdometryInCarmenAndGfsLayouts) {
  const std::string path = writeText("a.log",
                                     "ODOM 1 2 0.3 0.5 0.1 0.01 10 h 10.5\n"
                                     "ODOM 1.5 2 0.3 0.5 0.1 0.01 11\n"
                                     "ODOM 576.537 0.107 -2.255213 1134864629.895182\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 3u);
  for (const auto& r : records) EXPECT_EQ(r.kind, CarmenRecordKind::kOdometry);
  EXPECT_DOUBLE_EQ(records[0].odometry.pose.x(), 1.0);
  EXPECT_DOUBLE_EQ(records[0].odometry.linear_velocity, 0.5);
  EXPECT_DOUBLE_EQ(records[0].odometry.angular_velocity, 0.1);
  EXPECT_DOUBLE_EQ(records[0].odometry_acceleration, 0.01);
  EXPECT_DOUBLE_EQ(records[0].odometry.stamp, 10.0);
  EXPECT_DOUBLE_EQ(records[1].odometry.stamp, 11.0);
  EXPECT_DOUBLE_EQ(records[2].odometry.pose.theta(), -2.255213);
  EXPECT_DOUBLE_EQ(records[2].odometry.stamp, 1134864629.895182);
}

TEST(CarmenReader, GfsLaserReadingCarriesTheOdometryPose) {
  std::ostringstream line;
  line << "LASER_READING 3 1 2 3 576.48 -0.103 -1.487635 1134864642.914187\n";
  const std::string path =
      writeText("a.gfs", "PARAM maxrange 20\n" + line.str() + "SM_UPDATE 1 2 3\n");
  CarmenStats stats;
  const auto records = readAll(path, {}, &stats);
  ASSERT_EQ(records.size(), 2u);
  const CarmenLaser& laser = records[1].laser;
  EXPECT_EQ(records[1].type, "LASER_READING");
  EXPECT_DOUBLE_EQ(laser.laser_pose.x(), 576.48);
  EXPECT_DOUBLE_EQ(laser.odom_pose.x(), 576.48);
  EXPECT_DOUBLE_EQ(laser.scan.stamp, 1134864642.914187);
  EXPECT_DOUBLE_EQ(laser.scan.range_max, 20.0);  // from the .gfs PARAM maxrange
  EXPECT_EQ(stats.unknown.at("SM_UPDATE"), 1u);
}

TEST(CarmenReader, UnknownTypesAreSkippedAndCounted) {
  const std::string path = writeText("a.log",
                                     "NEFF 27.6 0 pippo 0\nTRUEPOS 1 2 3 4 5 6 7 h 7\nNEFF 1\n"
                                     "ODOM 0 0 0 0 0 0 1\n");
  CarmenStats stats;
  const auto records = readAll(path, {}, &stats);
  EXPECT_EQ(records.size(), 1u);
  EXPECT_EQ(stats.unknown.at("NEFF"), 2u);
  EXPECT_EQ(stats.unknown.at("TRUEPOS"), 1u);
  EXPECT_EQ(stats.unknownCount(), 3u);
  EXPECT_EQ(stats.skipped, 0u);
  EXPECT_NE(stats.summary().find("2 NEFF"), std::string::npos) << stats.summary();
}

struct BadLine {
  std::string line;
  std::string reason;   // expected statistics category
  std::string message;  // expected part of the error text
};

TEST(CarmenReader, MalformedLinesThrowInStrictModeWithFileAndLine) {
  const std::vector<BadLine> cases = {
      {"FLASER 5 1 2 3", "wrong token count", "FLASER with 5 readings"},
      {"FLASER 3 1 2 3 0 0 0 0 0 0 5 h 5 extra", "wrong token count", "found 13"},
      {"FLASER 3 1 2 3 nan 0 0 0 0 0 5 h 5", "non-finite value", "x must be finite"},
      {"FLASER 3 1 2 3 0 0 inf 0 0 0 5 h 5", "non-finite value", "theta must be finite"},
      {"FLASER 3 1 x 3 0 0 0 0 0 0 5 h 5", "not a number", "a range is not a number: 'x'"},
      {"FLASER -3 1 2 3 0 0 0 0 0 0 5", "bad count", "number of readings"},
      {"FLASER", "truncated line", "line ends before the number of readings"},
      {"ODOM 1 2 3 4 5", "wrong token count", "ODOM needs"},
      {"ODOM 1 2 3 4 5 6 nan", "non-finite value", "stamp must be finite"},
      {"ODOM 1 2 3 4 5 6 1e999", "not a number", "stamp is not a number"},
      {"ODOM 1 2 3 4 5 6 7 host", "wrong token count", "ODOM needs"},
      {"PARAM lonely", "wrong token count", "PARAM needs"},
      {"PARAM a b c", "wrong token count", "PARAM needs"},
      {"PARAM a b h nan", "non-finite value", "logger stamp must be finite"},
      {"ROBOTLASER1 0 -1 2 0.5 30 0.01 0 5 1 2 3", "wrong token count", "declares 5 readings"},
      {"ROBOTLASER1 0 -1 2 0 30 0.01 0 1 1 0 0 0 0 0 0 0 0 0 0 0 0 5", "invalid scan",
       "invalid angles"},
      {"RAWLASER1 0 -1 2 0.5 30 0.01 0 2 1 2 1 5", "wrong token count", "with 1 remissions"},
  };
  for (const BadLine& c : cases) {
    const std::string path = writeText("bad.log", "ODOM 0 0 0 0 0 0 1\n# note\n" + c.line + "\n");
    try {
      readAll(path, {});
      ADD_FAILURE() << "no error for: " << c.line;
    } catch (const CarmenError& e) {
      EXPECT_EQ(e.line(), 3u) << c.line;
      EXPECT_EQ(e.file(), path);
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(path + ":3: ", 0), 0u) << what;
      EXPECT_NE(what.find(c.message), std::string::npos) << c.line << " -> " << what;
    }
    CarmenStats stats;
    const auto records = readAll(path, lenient(), &stats);
    EXPECT_EQ(records.size(), 1u) << c.line;
    EXPECT_EQ(stats.skipped, 1u) << c.line;
    EXPECT_EQ(stats.skip_reasons.count(c.reason), 1u) << c.line << " reasons: " << stats.summary();
    ASSERT_FALSE(stats.problems.empty());
    EXPECT_NE(stats.problems.back().find(path + ":3: "), std::string::npos)
        << stats.problems.back();
  }
}

TEST(CarmenReader, LenientModeKeepsReadingAfterBadLines) {
  const std::string path = writeText("a.log",
                                     "ODOM 0 0 0 0 0 0 1\nFLASER 3 1 2\nODOM 1 0 0 0 0 0 2\n"
                                     "ODOM nan 0 0 0 0 0 3\nODOM 2 0 0 0 0 0 4\n");
  CarmenStats stats;
  const auto records = readAll(path, lenient(), &stats);
  ASSERT_EQ(records.size(), 3u);
  EXPECT_DOUBLE_EQ(records[2].odometry.pose.x(), 2.0);
  EXPECT_EQ(records[2].line, 5u);
  EXPECT_EQ(stats.skipped, 2u);
  EXPECT_EQ(stats.problems.size(), 2u);
  EXPECT_NE(stats.summary().find("skipped malformed: 2"), std::string::npos) << stats.summary();
}

// A whole-log read (storey slam's) that skipped lines says so: the front end's own report
// counts scans, not lines.
TEST(CarmenReader, AWholeLogReadSaysWhatItSkipped) {
  const std::string good = flaserLine(5, 1.0, "0 0 0 0 0 0 1 h 1");
  const std::string nan_pose = flaserLine(5, 1.0, "nan 0 0 0 0 0 2 h 2");
  const std::string path = writeText(
      "a.log", good + "\n" + nan_pose + "\nTHING 1 2\n" + good.substr(0, good.size() / 2));
  testing::internal::CaptureStderr();
  const CarmenLog log = readCarmenLog(path, lenient());
  const std::string warning = testing::internal::GetCapturedStderr();
  EXPECT_EQ(log.lasers.size(), 1u);
  EXPECT_EQ(log.stats.skipped, 2u);
  EXPECT_NE(warning.find(
                path + ": 3 lines skipped (2 unreadable, 1 of unknown types); first unreadable: " +
                path + ":2:"),
            std::string::npos)
      << warning;
  testing::internal::CaptureStderr();
  readCarmenLog(writeText("b.log", good + "\n"), lenient());
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(CarmenReader, TruncatedLastLineWithoutNewline) {
  const std::string good = flaserLine(5, 1.0, "0 0 0 0 0 0 1 h 1");
  const std::string path = writeText("a.log", good + "\n" + good.substr(0, good.size() / 2));
  EXPECT_THROW(readAll(path, {}), CarmenError);
  CarmenStats stats;
  EXPECT_EQ(readAll(path, lenient(), &stats).size(), 1u);
  EXPECT_EQ(stats.lines, 2u);
  EXPECT_EQ(stats.skipped, 1u);
  // A complete last line without a newline is fine.
  EXPECT_EQ(readAll(writeText("b.log", good), {}).size(), 1u);
}

TEST(CarmenReader, WindowsLineEndingsAndTabs) {
  const std::string path = writeText("a.log", "ODOM\t1 2 0 0 0 0 1\r\nODOM 1 2 0 0 0 0 2 h 2\r\n");
  const auto records = readAll(path, {});
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[1].host, "h");
  EXPECT_DOUBLE_EQ(records[1].logger_stamp, 2.0);
}

TEST(CarmenReader, LinesLongerThanTheReadBuffer) {
  const std::string line = flaserLine(30000, 1.0, "0 0 0 0 0 0 1 h 1");  // > 64 KiB
  ASSERT_GT(line.size(), 1u << 17);
  const std::string path =
      writeGzip("long.log.gz", "ODOM 0 0 0 0 0 0 1\n" + line + "\nODOM 0 0 0 0 0 0 2\n");
  CarmenStats stats;
  const auto records = readAll(path, {}, &stats);
  ASSERT_EQ(records.size(), 3u);
  EXPECT_EQ(records[1].laser.scan.ranges.size(), 30000u);
  EXPECT_NEAR(records[1].laser.scan.ranges[29999], 1.0 + 0.01 * 29999, 1e-3);
  EXPECT_EQ(records[2].line, 3u);
  EXPECT_EQ(stats.lines, 3u);
}

TEST(CarmenReader, ZeroLengthLogIsAnErrorWhenStrictAndEmptyWhenLenient) {
  for (const std::string& path : {writeText("empty.log", ""), writeGzip("empty.log.gz", "")}) {
    try {
      CarmenReader reader(path);
      ADD_FAILURE() << "no error for an empty log";
    } catch (const CarmenError& e) {
      EXPECT_NE(std::string(e.what()).find("the log is empty"), std::string::npos) << e.what();
      EXPECT_EQ(e.file(), path);
    }
    CarmenStats stats;
    EXPECT_TRUE(readAll(path, lenient(), &stats).empty());
    EXPECT_EQ(stats.lines, 0u);
  }
  // Only comments: not empty, but no records.
  EXPECT_TRUE(readAll(writeText("c.log", "# nothing\n"), {}).empty());
}

TEST(CarmenReader, MissingFileNamesThePath) {
  try {
    CarmenReader reader("/nonexistent/storey.log");
    FAIL() << "no error";
  } catch (const CarmenError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/storey.log"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

TEST(CarmenReader, ZeroAndOutOfOrderStampsAreReportedButKept) {
  const std::string path =
      writeText("a.log",
                "ODOM 0 0 0 0 0 0 0 h 0\n"
                "ODOM 0 0 0 0 0 0 5\n"
                "ODOM 0 0 0 0 0 0 4\n"        // earlier than 5
                "FLASER 1 1 0 0 0 0 0 0 3\n"  // FLASER stamps are checked on their own
                "ODOM 0 0 0 0 0 0 6\n");
  CarmenStats stats;
  const auto records = readAll(path, {}, &stats);
  EXPECT_EQ(records.size(), 5u);
  EXPECT_EQ(stats.zero_stamps, 1u);
  EXPECT_EQ(stats.out_of_order_stamps, 1u);
  ASSERT_EQ(stats.problems.size(), 2u);
  EXPECT_NE(stats.problems[1].find(":3: ODOM stamp 4 is earlier than the previous 5"),
            std::string::npos)
      << stats.problems[1];
  EXPECT_NE(stats.summary().find("1 zero, 1 out of order"), std::string::npos) << stats.summary();
}

CarmenLaser randomLaser(std::mt19937_64& rng, int beams) {
  std::uniform_real_distribution<double> u(-10, 10);
  std::uniform_real_distribution<float> r(0.1f, 30.0f);
  CarmenLaser laser;
  laser.scan.ranges.resize(beams);
  for (auto& v : laser.scan.ranges) v = r(rng);
  laser.scan.ranges[1] = std::numeric_limits<float>::quiet_NaN();
  laser.scan.ranges[2] = std::numeric_limits<float>::infinity();
  laser.scan.stamp = 1134864642.914187 + u(rng);
  laser.laser_pose = geometry::Pose2(u(rng), u(rng), u(rng));
  laser.odom_pose = geometry::Pose2(u(rng), u(rng), u(rng));
  laser.has_pose = true;
  return laser;
}

void expectSameRanges(const std::vector<float>& a, const std::vector<float>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]))
      EXPECT_TRUE(std::isnan(b[i])) << i;
    else
      EXPECT_EQ(a[i], b[i]) << i;  // exact: the writer prints round-trip text
  }
}

TEST(CarmenWriter, RoundTripsEveryRecordTypePlainAndGzip) {
  std::mt19937_64 rng(11);
  for (const std::string name : {"out.log", "out.log.gz"}) {
    const std::string path = test::makeTempDir("storey_io") + "/" + name;
    const CarmenLaser front = randomLaser(rng, 181);
    CarmenLaser robot = randomLaser(rng, 50);
    robot.scan.angle_min = -0.7;
    robot.scan.angle_increment = 0.02;
    robot.scan.range_max = 25.0;
    robot.remissions = {0.25f, 0.5f};
    const CarmenLaser gfs = randomLaser(rng, 361);
    sensor::OdometrySample odom;
    odom.stamp = 1234.5678901;
    odom.pose = geometry::Pose2(1.25, -3.5, 2.0);
    odom.linear_velocity = 0.4;
    odom.angular_velocity = -0.2;
    {
      CarmenWriter writer(path);
      writer.comment("written by storey");
      writer.param("robot_front_laser_max", "50", 1.0);
      writer.flaser(front);
      writer.flaser(front, 2);
      writer.robotLaser(robot);
      writer.odometry(odom, 0.05);
      writer.laserReading(gfs);
      writer.close();
    }
    if (name.size() > 3 && name.substr(name.size() - 3) == ".gz") {
      std::ifstream raw(path, std::ios::binary);
      unsigned char magic[2] = {0, 0};
      raw.read(reinterpret_cast<char*>(magic), 2);
      EXPECT_EQ(magic[0], 0x1f);  // gzip really
      EXPECT_EQ(magic[1], 0x8b);
    }
    CarmenStats stats;
    const auto records = readAll(path, {}, &stats);
    ASSERT_EQ(records.size(), 6u) << stats.summary();
    EXPECT_EQ(stats.comments, 1u);
    EXPECT_EQ(records[0].param_value, "50");
    for (int i : {1, 2}) {
      const CarmenLaser& back = records[i].laser;
      expectSameRanges(back.scan.ranges, front.scan.ranges);
      EXPECT_EQ(back.laser_pose.vector(), front.laser_pose.vector());
      EXPECT_EQ(back.odom_pose.vector(), front.odom_pose.vector());
      EXPECT_EQ(back.scan.stamp, front.scan.stamp);
      EXPECT_EQ(back.scan.range_max, 50.0 * (i == 1) + 80.0 * (i == 2));
    }
    EXPECT_EQ(records[2].type, "RLASER");
    const CarmenLaser& rb = records[3].laser;
    EXPECT_EQ(records[3].type, "ROBOTLASER1");
    expectSameRanges(rb.scan.ranges, robot.scan.ranges);
    EXPECT_EQ(rb.scan.angle_min, -0.7);
    EXPECT_EQ(rb.scan.angle_increment, 0.02);
    EXPECT_EQ(rb.scan.range_max, 25.0);
    EXPECT_EQ(rb.remissions, robot.remissions);
    EXPECT_EQ(rb.laser_pose.vector(), robot.laser_pose.vector());
    EXPECT_EQ(rb.odom_pose.vector(), robot.odom_pose.vector());
    const auto& ob = records[4];
    EXPECT_EQ(ob.odometry.pose.vector(), odom.pose.vector());
    EXPECT_EQ(ob.odometry.stamp, odom.stamp);
    EXPECT_EQ(ob.odometry.linear_velocity, 0.4);
    EXPECT_EQ(ob.odometry.angular_velocity, -0.2);
    EXPECT_EQ(ob.odometry_acceleration, 0.05);
    const CarmenLaser& gb = records[5].laser;
    expectSameRanges(gb.scan.ranges, gfs.scan.ranges);
    EXPECT_EQ(gb.laser_pose.vector(), gfs.laser_pose.vector());
    EXPECT_EQ(gb.scan.stamp, gfs.scan.stamp);
  }
}

TEST(CarmenWriter, UnwritablePathNamesIt) {
  try {
    CarmenWriter writer("/nonexistent/dir/out.log");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/out.log"), std::string::npos);
  }
}

TEST(CarmenReaderOptions, ReadStrictly) {
  auto node = common::ConfigNode::loadString("strict: false\ndefault_range_max: 30\n", "io.yaml");
  const CarmenReaderOptions o = readCarmenReaderOptions(node);
  EXPECT_FALSE(o.strict);
  EXPECT_DOUBLE_EQ(o.default_range_max, 30.0);
  EXPECT_DOUBLE_EQ(o.default_fov, M_PI);
  auto bad = common::ConfigNode::loadString("strict: true\nmax_rnage: 3\n", "io.yaml");
  EXPECT_THROW(readCarmenReaderOptions(bad), common::ConfigError);
  auto inverted =
      common::ConfigNode::loadString("range_min: 40\ndefault_range_max: 30\n", "io.yaml");
  EXPECT_THROW(readCarmenReaderOptions(inverted), common::ConfigError);
}

// The shared logs: counts from the data README and `zcat | awk '{print $1}' | sort | uniq -c`.
TEST(CarmenSharedLogs, IntelReadsEveryRecord) {
  STOREY_REQUIRE_DATA(path, "carmen/intel-corrected.log.gz");
  CarmenStats stats;
  std::size_t beams_ok = 0, corrected = 0;
  CarmenReader reader(path);
  CarmenRecord r;
  while (reader.next(&r)) {
    if (r.kind != CarmenRecordKind::kLaser) continue;
    beams_ok += r.laser.scan.ranges.size() == 180;
    // Corrected logs: the odometry fields repeat the corrected pose.
    corrected += (r.laser.laser_pose.vector() - r.laser.odom_pose.vector()).norm() < 1e-9;
  }
  stats = reader.stats();
  EXPECT_EQ(stats.recordCount("FLASER"), 910u);
  EXPECT_EQ(stats.recordCount("ODOM"), 14541u);
  EXPECT_EQ(stats.recordCount("PARAM"), 2u);
  EXPECT_EQ(stats.unknown.at("NEFF"), 910u);
  EXPECT_EQ(stats.skipped, 0u);
  EXPECT_EQ(beams_ok, 910u);
  EXPECT_EQ(corrected, 910u);
  std::cout << "intel: " << stats.summary() << "\n";
}

TEST(CarmenSharedLogs, EveryCorrectedLogAndTheGfsReadStrictly) {
  struct Expected {
    const char* file;
    const char* laser_type;
    std::size_t scans, beams;
  };
  for (const Expected& e :
       {Expected{"carmen/freiburg-079-corrected.log.gz", "FLASER", 4791, 360},
        Expected{"carmen/freiburg-101-corrected.log.gz", "FLASER", 292, 360},
        Expected{"carmen/csail-corrected.log.gz", "FLASER", 406, 361},
        Expected{"carmen/infinite-corridor-corrected.log.gz", "FLASER", 1941, 180},
        Expected{"carmen/csail.corrected.gfs.gz", "LASER_READING", 406, 361}}) {
    const std::string path = test::sharedDataPath(e.file);
    if (path.empty()) {
      std::cout << "skipping " << e.file << ": absent\n";
      continue;
    }
    std::size_t lasers = 0;
    for (const CarmenLaser& laser : readCarmenLasers(path)) {
      lasers += 1;
      EXPECT_EQ(laser.scan.ranges.size(), e.beams) << e.file;
    }
    CarmenReader reader(path);
    CarmenRecord r;
    while (reader.next(&r)) {
    }
    EXPECT_EQ(lasers, e.scans) << e.file;
    EXPECT_EQ(reader.stats().recordCount(e.laser_type), e.scans) << e.file;
    EXPECT_EQ(reader.stats().skipped, 0u);
    std::cout << e.file << ": " << reader.stats().summary() << "\n";
  }
}

}  // namespace
}  // namespace storey::io
