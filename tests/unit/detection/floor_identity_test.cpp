// Floor identity on arrival: an arrival the height alone does not decide names its
// candidate floors, and the detector waits for the mapper's answer before the next ride.
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"
#include "synthetic_ride.h"
#include "test_support.h"

namespace storey::detection {
namespace {

using test::ended;
using test::Script;
using test::SensorSetup;
using test::shippedOptions;

// Floor 0 -> floor 1 (3 m, seen), then half an hour without pressure in which the robot
// rides back down to floor 0, then a ride up 6 m. Over half an hour the weather may move
// the barometer by 50 Pa (max_drift_rate), about 4 m: the arrival after the gap could be
// any floor.
Script hiddenReturn() {
  Script script;
  script.wait(20.0).elevator(3.0).wait(60.0).wait(300.0).elevator(-3.0).wait(1500.0).wait(60.0);
  script.elevator(6.0).wait(40.0);
  return script;
}

SensorSetup gapSetup() {
  SensorSetup s;
  s.imu = s.odometry = s.scans = false;
  s.seed = 4;
  s.tamper = [](double t, double&) { return !(t > 100.0 && t < 1900.0); };
  return s;
}

TEST(FloorIdentity, AnArrivalHiddenInALongGapListsEveryFloorItsHeightAllows) {
  common::setLogLevel(common::LogLevel::kWarn);
  FloorDetector detector(shippedOptions());
  const auto ends = ended(test::run(hiddenReturn(), gapSetup(), detector));
  ASSERT_EQ(ends.size(), 3u);
  // The first ride is decided by its height.
  EXPECT_FALSE(ends[0].identityUnsure());
  // After the gap: floor 0 by the height, but floor 1 and a new floor are within reach.
  const FloorEvent& unsure = ends[1];
  EXPECT_EQ(unsure.floor_id, 0);
  EXPECT_GT(unsure.height_change_stddev, 1.0);
  ASSERT_EQ(unsure.candidate_floors.size(), 2u);
  EXPECT_EQ(unsure.candidate_floors[0], 0);  // nearest in height first
  EXPECT_EQ(unsure.candidate_floors[1], 1);
  EXPECT_EQ(unsure.new_floor_id, 2);
  // Nobody answered (no wait): the height's choice stands, the last ride goes from floor 0.
  EXPECT_EQ(ends[2].from_floor, 0);
  EXPECT_FALSE(detector.awaitingIdentity());
  EXPECT_EQ(detector.stats().unsure_arrivals, 1u);
  EXPECT_EQ(detector.stats().identities_not_answered, 1u);
}

TEST(FloorIdentity, TheAnswerNamesTheFloorLeftByTheNextRide) {
  common::setLogLevel(common::LogLevel::kWarn);
  // The mapper answers when the detector waits: its map says the robot is on floor 1.
  for (const int answer : {0, 1, 2}) {
    FloorDetector detector(shippedOptions());
    detector.awaitIdentity(3600.0);
    SensorSetup setup = gapSetup();
    double ride_end = -1.0;
    int waits = 0;
    setup.on_event = [&](FloorDetector& d, const FloorEvent& e) {
      if (e.type == FloorEventType::kTransitEnded && e.identityUnsure()) ride_end = e.stamp;
      if (e.type == FloorEventType::kAwaitingIdentity) {
        ++waits;
        EXPECT_EQ(e.stamp, ride_end);
        EXPECT_TRUE(d.holding());
        EXPECT_TRUE(d.setFloorIdentity({ride_end, answer, true}));
        EXPECT_FALSE(d.holding());
      }
    };
    const auto events = test::run(hiddenReturn(), setup, detector);
    EXPECT_EQ(waits, 1) << "answer " << answer;
    const auto ends = ended(events);
    ASSERT_EQ(ends.size(), 3u) << "answer " << answer;
    // The ride after the answer starts from the floor named, and is measured from it.
    std::vector<FloorEvent> starts;
    for (const auto& e : events)
      if (e.type == FloorEventType::kTransitStarted) starts.push_back(e);
    ASSERT_GE(starts.size(), 3u);
    EXPECT_EQ(starts.back().from_floor, answer) << "answer " << answer;
    EXPECT_EQ(ends[2].from_floor, answer) << "answer " << answer;
    const double named_height = answer == 1 ? 3.0 : 0.0;  // a new floor 2 is at the arrival's 0 m
    EXPECT_NEAR(ends[2].floor_height, named_height + 6.0, 0.3) << "answer " << answer;
    // Floors: 0, 1 and the one reached last; floor 2 when named, at the arrival's height.
    EXPECT_EQ(detector.floors().size(), answer == 2 ? 4u : 3u) << "answer " << answer;
    EXPECT_EQ(detector.stats().identities_changed, answer == 0 ? 0u : 1u);
  }
}

TEST(FloorIdentity, AnAnswerMakesNoDifferenceToWhenEventsAreDecided) {
  common::setLogLevel(common::LogLevel::kWarn);
  // The same answer given at once (on the TransitEnded) or when the detector waits: the
  // same events, stamps and decision times.
  std::vector<FloorEvent> runs[2];
  for (int way = 0; way < 2; ++way) {
    FloorDetector detector(shippedOptions());
    detector.awaitIdentity(3600.0);
    SensorSetup setup = gapSetup();
    setup.on_event = [&](FloorDetector& d, const FloorEvent& e) {
      const bool now = way == 0 ? e.type == FloorEventType::kTransitEnded && e.identityUnsure()
                                : e.type == FloorEventType::kAwaitingIdentity;
      if (now) d.setFloorIdentity({e.stamp, 1, true});
    };
    for (const auto& e : test::run(hiddenReturn(), setup, detector))
      if (e.type != FloorEventType::kAwaitingIdentity) runs[way].push_back(e);
  }
  ASSERT_EQ(runs[0].size(), runs[1].size());
  for (std::size_t i = 0; i < runs[0].size(); ++i) {
    EXPECT_EQ(runs[0][i].type, runs[1][i].type) << i;
    EXPECT_EQ(runs[0][i].stamp, runs[1][i].stamp) << i;
    EXPECT_EQ(runs[0][i].decided_at, runs[1][i].decided_at) << i;
    EXPECT_EQ(runs[0][i].from_floor, runs[1][i].from_floor) << i;
    EXPECT_EQ(runs[0][i].floor_id, runs[1][i].floor_id) << i;
    EXPECT_EQ(runs[0][i].height_change, runs[1][i].height_change) << i;
  }
}

// A detector restarted while it waits keeps the unsure arrival in its state file: the
// mapper's answer (kept for late readers) still names the floor after the restart.
TEST(FloorIdentity, AnAnswerAfterARestartIsApplied) {
  common::setLogLevel(common::LogLevel::kError);
  FloorDetector detector(shippedOptions());
  detector.awaitIdentity(3600.0);
  SensorSetup setup = gapSetup();
  std::optional<FloorDetectorState> saved;
  setup.on_event = [&](FloorDetector& d, const FloorEvent& e) {
    if (e.type == FloorEventType::kAwaitingIdentity && !saved) saved = d.state();
  };
  test::run(hiddenReturn(), setup, detector);
  ASSERT_TRUE(saved.has_value());
  ASSERT_TRUE(saved->pending_identity.has_value());
  const std::string path = storey::test::makeTempDir() + "/detector_state.yaml";
  writeFloorDetectorState(path, *saved);
  const FloorDetectorState read = readFloorDetectorState(path);
  ASSERT_TRUE(read.pending_identity.has_value());
  EXPECT_EQ(read.pending_identity->candidates, saved->pending_identity->candidates);
  EXPECT_EQ(read.pending_identity->new_floor_id, 2);
  const double ride_end = read.pending_identity->ride_end;
  for (const int answer : {0, 1, 2}) {
    FloorDetector restarted(shippedOptions());
    restarted.resume(read, 60.0);
    EXPECT_TRUE(restarted.awaitingIdentity());
    EXPECT_TRUE(restarted.setFloorIdentity({ride_end, answer, true})) << answer;
    EXPECT_FALSE(restarted.awaitingIdentity());
    EXPECT_EQ(restarted.state().current_floor, answer);
    EXPECT_FALSE(restarted.state().pending_identity.has_value());
    EXPECT_EQ(restarted.floors().size(), answer == 2 ? 3u : 2u) << answer;
  }
  // A state whose pending arrival names a floor it does not hold is refused.
  FloorDetectorState bad = read;
  bad.pending_identity->candidates.push_back(7);
  writeFloorDetectorState(path, bad);
  EXPECT_THROW(readFloorDetectorState(path), common::ConfigError);
}

TEST(FloorIdentity, WithoutAnAnswerTheDetectorGoesOnAfterItsWait) {
  common::setLogLevel(common::LogLevel::kError);
  FloorDetector detector(shippedOptions());
  detector.awaitIdentity(30.0);
  const auto events = test::run(hiddenReturn(), gapSetup(), detector);
  const auto ends = ended(events);
  ASSERT_EQ(ends.size(), 3u);
  EXPECT_EQ(ends[2].from_floor, 0);  // the height's choice
  EXPECT_NEAR(ends[2].height_change, 6.0, 0.3);
  EXPECT_FALSE(detector.holding());
  EXPECT_EQ(detector.stats().identities_not_answered, 1u);
}

TEST(FloorIdentity, AnAnswerThatIsNoCandidateOrForAnotherRideIsRefused) {
  common::setLogLevel(common::LogLevel::kError);
  FloorDetector detector(shippedOptions());
  detector.awaitIdentity(3600.0);
  SensorSetup setup = gapSetup();
  setup.on_event = [&](FloorDetector& d, const FloorEvent& e) {
    if (e.type != FloorEventType::kAwaitingIdentity) return;
    EXPECT_FALSE(d.setFloorIdentity({e.stamp + 1.0, 1, true}));  // another ride
    EXPECT_TRUE(d.holding());
    EXPECT_FALSE(d.setFloorIdentity({e.stamp, 7, true}));  // not a candidate: the height's choice
    EXPECT_FALSE(d.holding());
  };
  const auto ends = ended(test::run(hiddenReturn(), setup, detector));
  ASSERT_EQ(ends.size(), 3u);
  EXPECT_EQ(ends[2].from_floor, 0);
}

TEST(FloorIdentity, ARideDecidedByItsHeightHasNoCandidates) {
  common::setLogLevel(common::LogLevel::kWarn);
  FloorDetector detector(shippedOptions());
  detector.awaitIdentity(30.0);
  Script script;
  script.wait(20.0).elevator(3.0).wait(40.0).elevator(3.2).wait(40.0).elevator(-6.2).wait(40.0);
  script.stairs(3.0).wait(30.0);
  SensorSetup setup;
  setup.drift_pa_per_hour = 80.0;
  setup.seed = 11;
  const auto events = test::run(script, setup, detector);
  for (const auto& e : events) {
    EXPECT_FALSE(e.identityUnsure()) << "t=" << e.stamp;
    EXPECT_NE(e.type, FloorEventType::kAwaitingIdentity);
  }
  EXPECT_EQ(ended(events).size(), 4u);
  EXPECT_EQ(detector.stats().unsure_arrivals, 0u);
}

}  // namespace
}  // namespace storey::detection
