// A floor detector restarted from its saved state (FloorDetector::state/resume, the
// floor_detector component's state_file) goes on as the one that ran through.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "storey/common/config.h"
#include "storey/detection/floor_detector.h"
#include "synthetic_ride.h"
#include "test_support.h"

namespace storey::detection {
namespace {

using test::shippedOptions;

// Up 3.5 m at 32 s (the cabin moves 32-37.5 s), down again at 89.5 s.
test::Script twoRides() {
  test::Script script;
  script.wait(20.0).drive(10.0).elevator(3.5).drive(20.0).wait(30.0).elevator(-3.5).drive(20.0);
  return script;
}

// The pressure samples from `from` to `to` only (the detector is down outside).
test::SensorSetup between(double from, double to) {
  test::SensorSetup s;
  s.imu = s.odometry = s.scans = false;
  s.seed = 3;
  s.tamper = [from, to](double t, double&) { return t >= from && t <= to; };
  return s;
}

struct Restart {
  std::vector<FloorEvent> before, after;
  FloorDetectorState state;
};

// Runs until `stop_at`, saves the state through a file, and resumes a new detector on it
// that gets the samples from `resume_at` on.
Restart restartAt(double stop_at, double resume_at) {
  Restart r;
  const test::Script script = twoRides();
  FloorDetector first(shippedOptions());
  r.before = test::run(script, between(0.0, stop_at), first);
  const std::string path = storey::test::makeTempDir("detector_state") + "/state.yaml";
  writeFloorDetectorState(path, first.state());
  r.state = readFloorDetectorState(path);
  FloorDetector second(shippedOptions());
  second.resume(r.state);
  r.after = test::run(script, between(resume_at, 1e9), second);
  return r;
}

TEST(FloorDetectorResume, OnAFloorItGoesOnAsIfNeverStopped) {
  const Restart r = restartAt(60.0, 63.0);  // on the upper floor, between the rides
  ASSERT_EQ(test::ended(r.before).size(), 1u);
  EXPECT_EQ(r.state.current_floor, 1);
  EXPECT_FALSE(r.state.in_transit);
  // No event for the restart itself; the ride down ends on the known floor 0.
  ASSERT_EQ(r.after.size(), 2u);
  EXPECT_EQ(r.after[0].type, FloorEventType::kTransitStarted);
  EXPECT_EQ(r.after[0].from_floor, 1);
  EXPECT_EQ(r.after[1].floor_id, 0);
  EXPECT_FALSE(r.after[1].new_floor);
  EXPECT_NEAR(r.after[1].height_change, -3.5, 0.25);
}

TEST(FloorDetectorResume, InARideTheRideEndsOnTheRightFloor) {
  const Restart r = restartAt(37.0, 39.0);
  ASSERT_EQ(r.before.size(), 1u);  // TransitStarted was sent, TransitEnded not yet
  ASSERT_EQ(r.before[0].type, FloorEventType::kTransitStarted);
  EXPECT_TRUE(r.state.in_transit);
  const auto ended = test::ended(r.after);
  ASSERT_GE(ended.size(), 1u);
  EXPECT_EQ(r.after[0].type, FloorEventType::kTransitEnded);  // no second TransitStarted
  EXPECT_EQ(ended[0].floor_id, 1);
  EXPECT_TRUE(ended[0].new_floor);
  EXPECT_NEAR(ended[0].height_change, 3.5, 0.25);
}

TEST(FloorDetectorResume, ARideMissedWhileStoppedIsReported) {
  const Restart r = restartAt(25.0, 55.0);  // down through the whole first ride
  EXPECT_TRUE(r.before.empty());
  const auto ended = test::ended(r.after);
  ASSERT_GE(ended.size(), 1u);
  EXPECT_EQ(ended[0].floor_id, 1);
  EXPECT_TRUE(ended[0].new_floor);
  EXPECT_NEAR(ended[0].height_change, 3.5, 0.25);
  EXPECT_EQ(r.after[0].type, FloorEventType::kTransitStarted);  // the mapper needs both
}

TEST(FloorDetectorResume, SamplesUpToTheSavedStampAreSkipped) {
  const test::Script script = twoRides();
  FloorDetector first(shippedOptions());
  test::run(script, between(0.0, 60.0), first);
  FloorDetector second(shippedOptions());
  second.resume(first.state());
  // A durable topic delivers the whole history again: what was processed is skipped.
  const auto events = test::run(script, between(0.0, 1e9), second);
  EXPECT_EQ(second.stats().before_resume, 601u);  // 0.0 ... 60.0 s at 10 Hz
  ASSERT_EQ(test::ended(events).size(), 1u);
  EXPECT_EQ(test::ended(events)[0].floor_id, 0);
}

TEST(FloorDetectorResume, ABadStateFileNamesTheFileAndTheKey) {
  const std::string path = storey::test::makeTempDir("detector_state_bad") + "/state.yaml";
  FloorDetectorState s;
  s.floors.push_back(Floor{0, 0.0, 1, true});
  s.current_floor = 0;
  writeFloorDetectorState(path, s);
  EXPECT_EQ(readFloorDetectorState(path).floors.size(), 1u);
  {
    std::ifstream in(path);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("current_floor: 0"), 16, "current_floor: 4");
    std::ofstream(path) << text;
  }
  try {
    readFloorDetectorState(path);
    FAIL() << "a state on floor 4 of 1 was accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("current_floor"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace storey::detection
