#include "storey/mapping/input_sequencer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace storey::mapping {
namespace {

using floor::FloorEvent;
using floor::FloorEventType;

// One input on one of the three topics.
struct Input {
  enum Topic { kScan, kOdometry, kEvents } topic;
  double stamp;  // scan or odometry stamp, or the event's decided_at
  FloorEventType type = FloorEventType::kProgress;
};

// A robot's recording: scans and odometry at 10 Hz (odometry 0.05 s behind), a ride
// decided at 12.34 (began at 11.0) and ended at 20.57, the detector's progress every 0.5 s.
std::vector<Input> recording() {
  std::vector<Input> in;
  for (int i = 0; i < 300; ++i) {
    const double t = 0.1 * i;
    in.push_back({Input::kScan, t});
    in.push_back({Input::kOdometry, t + 0.05});
  }
  for (int i = 1; i <= 60; ++i) in.push_back({Input::kEvents, 0.5 * i});
  in.push_back({Input::kEvents, 12.34, FloorEventType::kTransitStarted});
  in.push_back({Input::kEvents, 20.57, FloorEventType::kTransitEnded});
  // Each topic in its own order; events before the progress message of the same stamp.
  std::stable_sort(in.begin(), in.end(), [](const Input& a, const Input& b) {
    if (a.topic != b.topic) return a.topic < b.topic;
    if (a.stamp != b.stamp) return a.stamp < b.stamp;
    return a.type < b.type;
  });
  return in;
}

// The same inputs delivered in another interleaving: each topic keeps its own order (as
// one DDS writer's samples do), the topics are shuffled against each other.
std::vector<Input> interleave(const std::vector<Input>& in, unsigned seed) {
  std::vector<std::vector<Input>> topics(3);
  for (const auto& i : in) topics[i.topic].push_back(i);
  std::mt19937 rng(seed);
  std::vector<Input> out;
  std::vector<std::size_t> next(3, 0);
  while (out.size() < in.size()) {
    const int t = std::uniform_int_distribution<int>(0, 2)(rng);
    // Bursts: a topic may run several samples ahead of the others.
    const int burst = std::uniform_int_distribution<int>(1, 20)(rng);
    for (int k = 0; k < burst && next[t] < topics[t].size(); ++k) out.push_back(topics[t][next[t]++]);
  }
  return out;
}

// What the sequencer passed on, one line per call.
std::string run(const std::vector<Input>& inputs, InputSequencerOptions options = {}) {
  std::ostringstream trace;
  InputSequencer sequencer(
      options,
      [&](const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
        trace << "scan " << scan.stamp << " x " << odometry.x() << "\n";
      },
      [&](const FloorEvent& e) { trace << "event " << static_cast<int>(e.type) << " at " << e.decided_at << "\n"; });
  for (const auto& i : inputs) {
    if (i.topic == Input::kScan) {
      sensor::LaserScan scan;
      scan.stamp = i.stamp;
      sequencer.addScan(scan);
    } else if (i.topic == Input::kOdometry) {
      sensor::OdometrySample o;
      o.stamp = i.stamp;
      o.pose = geometry::Pose2(i.stamp, 0.0, 0.0);  // x is the stamp: interpolation shows
      sequencer.addOdometry(o);
    } else {
      FloorEvent e;
      e.type = i.type;
      e.stamp = i.type == FloorEventType::kProgress ? i.stamp : i.stamp - 1.0;
      e.decided_at = i.stamp;
      sequencer.addFloorEvent(e);
    }
  }
  sequencer.flush();
  return trace.str();
}

TEST(InputSequencer, EventsGoBetweenTheScansAroundTheirDecision) {
  const std::string trace = run(interleave(recording(), 1));
  EXPECT_NE(trace.find("scan 12.3 x 12.3\nevent 0 at 12.34\nscan 12.4 x 12.4\n"), std::string::npos) << trace;
  EXPECT_NE(trace.find("scan 20.5 x 20.5\nevent 1 at 20.57\nscan 20.6 x 20.6\n"), std::string::npos) << trace;
  EXPECT_EQ(std::count(trace.begin(), trace.end(), '\n'), 302);
}

TEST(InputSequencer, SameOrderWhateverTheInterleaving) {
  const std::vector<Input> in = recording();
  const std::string reference = run(in);
  for (unsigned seed = 1; seed <= 50; ++seed) EXPECT_EQ(run(interleave(in, seed)), reference) << "seed " << seed;
}

TEST(InputSequencer, WithoutWaitingForTheDetectorTheOrderDependsOnArrival) {
  // The check above is not vacuous: ordering by arrival (the mapper before) differs.
  InputSequencerOptions options;
  options.wait_for_floor_detector = false;
  const std::vector<Input> in = recording();
  int differing = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) differing += run(interleave(in, seed), options) != run(in, options);
  EXPECT_GT(differing, 0);
}

TEST(InputSequencer, ADeadDetectorHoldsScansOnlyForTheLag) {
  std::vector<Input> in;
  for (int i = 0; i < 100; ++i) {
    in.push_back({Input::kOdometry, 0.1 * i});
    in.push_back({Input::kScan, 0.1 * i});
  }
  InputSequencerOptions options;
  options.max_floor_detector_lag = 2.05;
  int scans = 0;
  InputSequencer sequencer(
      options, [&](const sensor::LaserScan&, const geometry::Pose2&) { ++scans; }, [](const FloorEvent&) {});
  for (const auto& i : in) {
    if (i.topic == Input::kScan) {
      sensor::LaserScan s;
      s.stamp = i.stamp;
      sequencer.addScan(s);
    } else {
      sensor::OdometrySample o;
      o.stamp = i.stamp;
      sequencer.addOdometry(o);
    }
  }
  // Scans up to 9.9 - 2.0 went on without the detector; the last 2 s wait.
  EXPECT_EQ(scans, 79);
  EXPECT_EQ(sequencer.stats().released_by_lag, 79u);
  EXPECT_EQ(sequencer.scansWaiting(), 21u);
  sequencer.flush();
  EXPECT_EQ(scans, 100);
}

TEST(InputSequencer, ScansWithoutOdometryAreDroppedAndOutOfOrderScansRefused) {
  int scans = 0;
  InputSequencerOptions options;
  options.wait_for_floor_detector = false;
  InputSequencer sequencer(
      options, [&](const sensor::LaserScan&, const geometry::Pose2&) { ++scans; }, [](const FloorEvent&) {});
  sensor::OdometrySample o;
  o.stamp = 10.0;
  sequencer.addOdometry(o);
  sensor::LaserScan s;
  s.stamp = 5.0;  // odometry 5 s away: more than max_odometry_gap
  sequencer.addScan(s);
  s.stamp = 9.8;
  sequencer.addScan(s);
  s.stamp = 9.7;  // older than the last
  sequencer.addScan(s);
  s.stamp = std::numeric_limits<double>::quiet_NaN();
  sequencer.addScan(s);
  sequencer.flush();
  EXPECT_EQ(scans, 1);
  EXPECT_EQ(sequencer.stats().scans_without_odometry, 1u);
}

TEST(InputSequencer, EventsSentAgainByARestartedDetectorAreTakenOnce) {
  std::vector<Input> in = recording();
  // The detector restarted at 22 s and, given the sensor history again, sent its events
  // and progress from the start once more.
  for (int i = 1; i <= 44; ++i) in.push_back({Input::kEvents, 0.5 * i});
  in.push_back({Input::kEvents, 12.34, FloorEventType::kTransitStarted});
  in.push_back({Input::kEvents, 20.57, FloorEventType::kTransitEnded});
  std::stable_sort(in.begin(), in.end(), [](const Input& a, const Input& b) { return a.topic < b.topic; });
  EXPECT_EQ(run(interleave(in, 3)), run(recording()));
}

TEST(InputSequencer, PausedItOnlyQueuesAndAfterAResumeItSkipsWhatWasMapped) {
  std::vector<double> scans;
  InputSequencerOptions options;
  options.wait_for_floor_detector = false;
  InputSequencer sequencer(
      options, [&](const sensor::LaserScan& s, const geometry::Pose2&) { scans.push_back(s.stamp); },
      [](const FloorEvent&) { ADD_FAILURE() << "an event logged before the restart was taken again"; });
  sequencer.setPaused(true);
  // A restart: the log had scans up to 2.0 (2.05: stamps below are sums of 0.1) and an
  // event decided at 1.5.
  sequencer.resumeAfter(2.05, 1.5);
  for (int i = 0; i <= 40; ++i) {  // the sensor topics' history, from the start
    sensor::OdometrySample o;
    o.stamp = 0.1 * i;
    sequencer.addOdometry(o);
    sensor::LaserScan s;
    s.stamp = 0.1 * i;
    sequencer.addScan(s);
  }
  FloorEvent e;
  e.type = FloorEventType::kTransitStarted;
  e.decided_at = 1.5;
  sequencer.addFloorEvent(e);
  EXPECT_TRUE(scans.empty());
  sequencer.setPaused(false);
  ASSERT_FALSE(scans.empty());
  EXPECT_GT(scans.front(), 2.0);
  EXPECT_NEAR(scans.back(), 4.0, 1e-9);
  EXPECT_EQ(sequencer.stats().already_mapped, 22u);  // scans 0.0 ... 2.0, and the event
}

// The keys sit at the top of the floor mapper's file, beside its others: read there, out of
// range refused naming file, line and key; keys it does not know are left to the file's reader.
TEST(InputSequencerOptions, ReadFromTheFloorMappersKeys) {
  const common::ConfigNode root = common::ConfigNode::loadString(
      "robot: r\nmax_odometry_gap: 2.5\nwait_for_floor_detector: false\nmax_floor_detector_lag: "
      "4\n",
      "mapper.yaml");
  const InputSequencerOptions o = readInputSequencerOptions(root);
  EXPECT_DOUBLE_EQ(o.max_odometry_gap, 2.5);
  EXPECT_FALSE(o.wait_for_floor_detector);
  EXPECT_DOUBLE_EQ(o.max_floor_detector_lag, 4.0);
  EXPECT_DOUBLE_EQ(
      readInputSequencerOptions(common::ConfigNode::loadString("robot: r\n")).max_odometry_gap,
      InputSequencerOptions{}.max_odometry_gap);
  try {
    readInputSequencerOptions(
        common::ConfigNode::loadString("robot: r\nmax_odometry_gap: 0\n", "mapper.yaml"));
    FAIL() << "a gap of 0 s was accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mapper.yaml:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("max_odometry_gap"), std::string::npos) << e.what();
  }
}

// A recording's scans paired with its odometry stream, as live: interpolated at each
// scan's stamp between samples at most max_odometry_gap apart, none where no sample is
// within max_odometry_gap.
TEST(InputSequencer, RecordedScansArePairedWithOdometryAtTheirStamps) {
  std::vector<sensor::LaserScan> scans(4);
  for (std::size_t i = 0; i < scans.size(); ++i)
    scans[i].stamp = std::vector<double>{0.5, 1.0, 1.0, 5.0}[i];
  std::vector<sensor::OdometrySample> odometry(3);
  for (int i = 0; i < 3; ++i) {
    odometry[i].stamp = i;
    odometry[i].pose = geometry::Pose2(2.0 * i, 0.0, 0.1 * i);
  }
  InputSequencerOptions options;
  options.max_odometry_gap = 1.0;  // samples 1 s apart are interpolated between
  const auto paired = odometryAtScans(scans, odometry, options);
  ASSERT_EQ(paired.size(), 4u);
  ASSERT_TRUE(paired[0] && paired[1] && paired[2]);
  EXPECT_NEAR(paired[0]->x(), 1.0, 1e-12);
  EXPECT_NEAR(paired[0]->theta(), 0.05, 1e-12);
  EXPECT_NEAR(paired[1]->x(), 2.0, 1e-12);
  EXPECT_NEAR(paired[2]->x(), 2.0, 1e-12);
  EXPECT_FALSE(paired[3]);  // 3 s after the last sample
  InputSequencerOptions wide_gap;
  wide_gap.max_odometry_gap = 5.0;
  const auto held = odometryAtScans(scans, odometry, wide_gap);
  ASSERT_TRUE(held[3]);
  EXPECT_NEAR(held[3]->x(), 4.0, 1e-12);  // the last sample, held
}

}  // namespace
}  // namespace storey::mapping
