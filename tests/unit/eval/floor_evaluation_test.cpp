#include "storey/eval/floor_evaluation.h"

#include <gtest/gtest.h>

#include <fstream>

#include "test_support.h"

namespace storey::eval {
namespace {

using floor::FloorEvent;
using floor::FloorEventType;
using floor::TransitMode;

FloorEvent change(double start, double end, int from, int to, double dz, bool created) {
  FloorEvent e;
  e.type = FloorEventType::kTransitEnded;
  e.start_stamp = start;
  e.stamp = end;
  e.from_floor = from;
  e.floor_id = to;
  e.height_change = dz;
  e.floor_changed = true;
  e.new_floor = created;
  e.mode = TransitMode::kElevator;
  return e;
}

TrueTransit truth(double start, double end, const char* from, const char* to, double dz) {
  TrueTransit t;
  t.robot = "r";
  t.start = start;
  t.end = end;
  t.from_floor = from;
  t.to_floor = to;
  t.height_change = dz;
  t.mode = "elevator";
  return t;
}

TEST(FloorEvaluation, ExactSequenceAndHeightError) {
  const std::vector<FloorEvent> events = {change(8, 20, 0, 1, 3.1, true),
                                          change(48, 60, 1, 0, -2.9, false)};
  const std::vector<TrueTransit> t = {truth(10, 15, "A", "B", 3.0), truth(50, 55, "B", "A", -3.0)};
  const FloorComparison c = compareWithTruth(events, t);
  EXPECT_TRUE(c.exact());
  EXPECT_EQ(c.matched, 2);
  EXPECT_NEAR(c.height_rmse, 0.1, 1e-9);
  EXPECT_EQ(c.mode_correct, 2);
}

TEST(FloorEvaluation, MissedSpuriousAndWrongFloors) {
  // Truth: A -> B -> C -> A. Reported: a spurious change before the first ride, the
  // second ride missed, and the return to A reported as a new floor.
  const std::vector<FloorEvent> events = {change(0, 3, 0, 1, 1.5, true),
                                          change(8, 20, 1, 2, 1.5, true),
                                          change(148, 160, 2, 3, -6.0, true)};
  const std::vector<TrueTransit> t = {truth(30, 35, "A", "B", 3.0), truth(90, 95, "B", "C", 3.0),
                                      truth(150, 155, "C", "A", -6.0)};
  const FloorComparison c = compareWithTruth(events, t, 5.0);
  EXPECT_FALSE(c.exact());
  EXPECT_EQ(c.spurious, 2);  // the change at 0..3 s and the one at 8..20 s (nothing true then)
  EXPECT_EQ(c.missed, 2);    // rides at 30 s and 90 s
  EXPECT_EQ(c.matched, 1);
  EXPECT_EQ(c.wrong_floor, 1);  // floor A came back as a new detector floor
  EXPECT_EQ(c.problems.size(), 5u);
}

TEST(FloorEvaluation, ReadsGroundTruthByColumnNameAndRejectsBadRows) {
  const std::string dir = storey::test::makeTempDir("fd_truth");
  {
    std::ofstream f(dir + "/floors.yaml");
    f << "building: b\nfloors:\n  - {id: F0, height: 0.0, frame: [0, 0, 0]}\n"
         "  - {id: F1, height: 3.5, frame: [0, 0, 0]}\n";
    std::ofstream t(dir + "/transits.csv");
    t << "robot,start,end,from_floor,to_floor,mode,extra\n"
         "r1,10.5,15.0,F0,F1,elevator,0.1\n"
         "r1,40.0,70.0,F1,F0,stairs,0.0\n";
  }
  const auto transits = readTrueTransits(dir);
  ASSERT_EQ(transits.size(), 2u);
  EXPECT_EQ(transits[0].robot, "r1");
  EXPECT_DOUBLE_EQ(transits[0].start, 10.5);
  EXPECT_DOUBLE_EQ(transits[0].height_change, 3.5);
  EXPECT_DOUBLE_EQ(transits[1].height_change, -3.5);
  EXPECT_EQ(transits[1].mode, "stairs");
  {
    std::ofstream t(dir + "/transits.csv");
    t << "robot,start,end,from_floor,to_floor,mode\nr1,ten,15.0,F0,F1,elevator\n";
  }
  try {
    readTrueTransits(dir);
    FAIL() << "a bad number was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("transits.csv:2"), std::string::npos) << e.what();
  }
  {
    std::ofstream t(dir + "/transits.csv");
    t << "robot,start,end,from_floor,to_floor,mode\nr1,1,2,F0,F9,elevator\n";
  }
  EXPECT_THROW(readTrueTransits(dir), std::runtime_error);
}

}  // namespace
}  // namespace storey::eval
