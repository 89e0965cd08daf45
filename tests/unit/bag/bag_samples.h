// Sample bags for the bag tests: messages written over three topics, read back, compared.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"

namespace storey::bag::samples {

struct Written {
  std::string topic;
  std::int64_t stamp;
  std::vector<std::uint8_t> data;
};

inline std::vector<std::uint8_t> randomBytes(std::mt19937& rng, std::size_t size) {
  std::vector<std::uint8_t> bytes(size);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng() & 0xff);
  return bytes;
}

// Writes `count` messages cycling over three topics with jittered (unordered) stamps.
inline std::vector<Written> writeSample(const std::string& folder, int count, std::size_t max_size,
                                        std::int64_t t0 = 1'700'000'000'000'000'000,
                                        unsigned seed = 7,
                                        const std::string& storage = kStorageSqlite3) {
  std::mt19937 rng(seed);
  BagWriter writer(folder, BagWriterOptions{64, "humble", storage});
  writer.createTopic(
      {"/r1/scan", "sensor_msgs/msg/LaserScan", "cdr", qosProfileYaml(false, false)});
  writer.createTopic({"/r1/odom", "nav_msgs/msg/Odometry", "cdr", qosProfileYaml(false, false)});
  writer.createTopic({"/graph", "storey_msgs/msg/FloorGraph", "cdr", qosProfileYaml(true, true)});
  const char* names[] = {"/r1/scan", "/r1/odom", "/graph"};
  std::vector<Written> written;
  for (int i = 0; i < count; ++i) {
    Written w;
    w.topic = names[i % 3];
    w.stamp = t0 + std::int64_t{i} * 10'000'000 + static_cast<std::int64_t>(rng() % 30'000'000);
    w.data = randomBytes(rng, rng() % (max_size + 1));
    writer.write(w.topic, w.stamp, w.data);
    written.push_back(std::move(w));
  }
  writer.close();
  return written;
}

inline std::vector<Written> readAll(BagReader& reader) {
  std::vector<Written> out;
  BagMessage m;
  while (reader.next(m)) out.push_back({reader.topics()[m.topic_index].name, m.stamp_ns, m.data});
  return out;
}

inline std::vector<Written> timeOrdered(std::vector<Written> w) {
  std::stable_sort(w.begin(), w.end(),
                   [](const Written& a, const Written& b) { return a.stamp < b.stamp; });
  return w;
}

inline void expectSame(const std::vector<Written>& expected, const std::vector<Written>& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(expected[i].topic, actual[i].topic) << "message " << i;
    EXPECT_EQ(expected[i].stamp, actual[i].stamp) << "message " << i;
    EXPECT_EQ(expected[i].data, actual[i].data) << "message " << i;
  }
}

// The three topics writeSample declares, as a reader gives them back, and its messages
// in time order (twice: rewinding replays the same stream).
inline void expectTheSample(BagReader& reader, const std::vector<Written>& written) {
  ASSERT_EQ(reader.topics().size(), 3u);
  EXPECT_EQ(reader.topics()[0].name, "/r1/scan");
  EXPECT_EQ(reader.topics()[0].type, "sensor_msgs/msg/LaserScan");
  EXPECT_EQ(reader.topics()[2].type, "storey_msgs/msg/FloorGraph");
  EXPECT_EQ(reader.topics()[2].serialization_format, "cdr");
  EXPECT_EQ(reader.topics()[2].offered_qos_profiles, qosProfileYaml(true, true));
  expectSame(timeOrdered(written), readAll(reader));
  reader.rewind();
  expectSame(timeOrdered(written), readAll(reader));
}

// The reader's time span is the written messages' earliest and latest stamp.
inline void expectTimeSpan(BagReader& reader, const std::vector<Written>& written) {
  std::int64_t lo = written.at(0).stamp, hi = written.at(0).stamp;
  for (const auto& w : written) {
    lo = std::min(lo, w.stamp);
    hi = std::max(hi, w.stamp);
  }
  EXPECT_EQ(reader.startTimeNs(), lo);
  EXPECT_EQ(reader.endTimeNs(), hi);
}

}  // namespace storey::bag::samples
