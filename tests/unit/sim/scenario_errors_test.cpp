// Bad building files and impossible missions must fail with the file, line and key at
// fault and say what is wrong.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "storey/sim/scenario.h"
#include "test_support.h"

namespace storey::sim {
namespace {

// A valid two-floor scenario; tests replace one marked line to break it.
const char* const kBase = R"(name: t
building:
  name: t
  shafts:
    - {id: E, kind: elevator, center: [5.0, 5.0], size: [2.0, 2.0], door_side: south}
    - {id: S, kind: stairs, center: [15.0, 5.0], size: [2.4, 4.0], door_side: south, floors: [A, B]}
  floors:
    - id: A
      height: 0.0
      walls:
        - {id: outer, rect: [[0.0, 0.0], [20.0, 10.0]]}
        - {polyline: [[8.0, 0.0], [8.0, 2.0]]}  #WALL
      doors:
        - {id: d, span: [[8.0, 0.5], [8.0, 1.5]], open: true}  #DOOR
      furniture:
        - {id: table, center: [2.0, 2.0], size: [1.0, 1.0]}  #FURNITURE
    - id: B
      height: 3.0  #HEIGHT
      like: A
    - id: C
      height: 6.0
      like: A
robots:
  - name: r
    model: {laser: {rate: 2.0, fov_deg: 180, beams: 19, max_range: 20.0, range_sigma: 0.01},
            odometry: {rate: 10, translation_sigma: 0.01, rotation_sigma: 0.01, rotation_per_metre_sigma: 0.001},
            barometer: {rate: 5, sigma: 1.0}, imu: {rate: 20, accel_sigma: 0.01, gyro_sigma: 0.001},
            motion: {speed: 0.5, acceleration: 0.5, turn_rate_deg: 90, angular_acceleration_deg: 180,
                     stairs_speed: 0.3, elevator_speed: 1.0, elevator_acceleration: 0.5,
                     door_time: 1.0, radius: 0.25}}
    start: {floor: A, pose: [3.0, 1.0, 0.0]}
    mission:
      - {go: [5.0, 3.0]}  #STEP1
      - {elevator: E, to: B}  #STEP2
)";

std::string replaceLine(const std::string& marker, const std::string& replacement,
                        std::string text = kBase) {
  const auto at = text.find("#" + marker);
  EXPECT_NE(at, std::string::npos) << marker;
  const auto begin = text.rfind('\n', at) + 1;
  text.replace(begin, at + marker.size() + 1 - begin, replacement);
  return text;
}

// The error text for a scenario, or "" when it loads.
std::string errorOf(const std::string& text) {
  try {
    loadScenarioString(text, "test.yaml");
  } catch (const common::ConfigError& e) {
    return e.what();
  }
  return "";
}

int lineOf(const std::string& text, const std::string& needle) {
  const auto at = text.find(needle);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
}

TEST(ScenarioErrors, TheBaseScenarioLoads) {
  EXPECT_EQ(errorOf(kBase), "");
  const Scenario s = loadScenarioString(kBase, "test.yaml");
  EXPECT_EQ(s.building.floors.size(), 3u);
  EXPECT_EQ(s.building.floors[1].walls.size(), 2u);  // copied by `like`
}

TEST(ScenarioErrors, DegenerateWall) {
  const std::string text = replaceLine("WALL", "        - {polyline: [[8.0, 0.0], [8.0, 0.01]]}");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "[8.0, 0.01]"))),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("degenerate segment"), std::string::npos) << error;
  EXPECT_NE(error.find("floors[0].walls[1].polyline"), std::string::npos) << error;
}

// A corner that is not a finite number is an error naming its line (drawn, it would drop
// the walls it bounds).
TEST(ScenarioErrors, NonFiniteWallCorner) {
  for (const std::string bad : {".nan", ".inf", "-.inf"}) {
    const std::string text =
        replaceLine("WALL", "        - {polyline: [[8.0, 0.0], [8.0, " + bad + "]]}");
    const std::string error = errorOf(text);
    EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, bad + "]]"))),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("expected a finite number"), std::string::npos) << error;
  }
  const std::string outer = replaceLine("WALL", "        - {polyline: [[.nan, 0.0], [8.0, 2.0]]}");
  EXPECT_NE(errorOf(outer).find("floors[0].walls[1].polyline[0][0]"), std::string::npos)
      << errorOf(outer);
}

// yaml-cpp keeps the first of two equal keys: the file is refused, naming both lines.
TEST(ScenarioErrors, DuplicateKey) {
  const std::string text = replaceLine("HEIGHT", "      height: 3.0\n      height: 30.0");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "height: 30.0"))),
            std::string::npos)
      << error;
  EXPECT_NE(
      error.find("duplicate key (also on line " + std::to_string(lineOf(text, "height: 3.0\n"))),
      std::string::npos)
      << error;
}

TEST(ScenarioErrors, DoorNotOnAWall) {
  const std::string text =
      replaceLine("DOOR", "        - {id: d, span: [[9.0, 0.5], [9.0, 1.5]], open: true}");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "[9.0, 0.5]"))),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("does not lie on a wall"), std::string::npos) << error;
}

TEST(ScenarioErrors, FurnitureThroughAWall) {
  const std::string text =
      replaceLine("FURNITURE", "        - {id: table, center: [8.0, 1.8], size: [1.0, 1.0]}");
  EXPECT_NE(errorOf(text).find("furniture 'table' on floor A overlaps a wall"), std::string::npos)
      << errorOf(text);
}

TEST(ScenarioErrors, FurnitureInsideAShaft) {
  const std::string text =
      replaceLine("FURNITURE", "        - {id: table, center: [5.0, 5.0], size: [0.5, 0.5]}");
  EXPECT_NE(errorOf(text).find("inside shaft 'E'"), std::string::npos) << errorOf(text);
}

TEST(ScenarioErrors, WallIntoAShaft) {
  const std::string text = replaceLine("WALL",
                                       "        - {polyline: [[8.0, 0.0], [8.0, 2.0]]}\n        - "
                                       "{polyline: [[3.0, 5.0], [5.0, 5.0]]}");
  EXPECT_NE(errorOf(text).find("runs into shaft 'E'"), std::string::npos) << errorOf(text);
}

TEST(ScenarioErrors, FloorsOutOfOrder) {
  const std::string text = replaceLine("HEIGHT", "      height: -3.0");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("floors[1].height"), std::string::npos) << error;
  EXPECT_NE(error.find("bottom up"), std::string::npos) << error;
}

TEST(ScenarioErrors, UnknownKeyIsNamedWithItsLine) {
  const std::string text = replaceLine("HEIGHT", "      height: 3.0\n      colour: red");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "colour"))), std::string::npos)
      << error;
  EXPECT_NE(error.find("floors[1].colour: unknown key"), std::string::npos) << error;
}

TEST(ScenarioErrors, WaypointInsideAWall) {
  const std::string text = replaceLine("STEP1", "      - {go: [8.05, 1.8]}");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "[8.05, 1.8]"))),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("mission[0]"), std::string::npos) << error;
  EXPECT_NE(error.find("waypoint (8.05, 1.8)"), std::string::npos) << error;
}

TEST(ScenarioErrors, PathThroughAWall) {
  const std::string text = replaceLine("STEP1", "      - {go: [10.0, 0.3]}");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("mission[0]"), std::string::npos) << error;
  EXPECT_NE(error.find("crosses or grazes a wall"), std::string::npos) << error;
}

TEST(ScenarioErrors, PathThroughTheOpenDoorIsFine) {
  const std::string there = replaceLine("STEP1", "      - {go: [10.0, 1.0]}");
  EXPECT_EQ(errorOf(replaceLine("STEP2", "      - {go: [3.0, 1.0]}", there)), "");
}

TEST(ScenarioErrors, PathThroughAClosedDoorIsNot) {
  const std::string closed = replaceLine(
      "STEP1", "      - {go: [10.0, 1.0]}",
      replaceLine("DOOR", "        - {id: d, span: [[8.0, 0.5], [8.0, 1.5]], open: false}"));
  EXPECT_NE(errorOf(closed).find("crosses or grazes a wall"), std::string::npos) << errorOf(closed);
}

TEST(ScenarioErrors, FloorWithoutElevatorOrStairs) {
  std::string text = kBase;
  const std::string elevator = "door_side: south}\n";
  text.replace(text.find(elevator), elevator.size(), "door_side: south, floors: [A, B]}\n");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("floor C is served by no elevator or stairwell"), std::string::npos)
      << error;
  EXPECT_NE(error.find("test.yaml:" + std::to_string(lineOf(text, "- id: C"))), std::string::npos)
      << error;
}

TEST(ScenarioErrors, RideToAFloorTheElevatorDoesNotReach) {
  std::string text = replaceLine("STEP2", "      - {elevator: E, to: C}");
  EXPECT_EQ(errorOf(text), "");  // E serves all floors
  text = replaceLine("STEP2", "      - {stairs: S, to: C}");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("shaft 'S' does not reach floor C"), std::string::npos) << error;
  EXPECT_NE(error.find("mission[1]"), std::string::npos) << error;
}

TEST(ScenarioErrors, RideInAStairwellOrToAnUnknownFloor) {
  EXPECT_NE(
      errorOf(replaceLine("STEP2", "      - {elevator: S, to: B}")).find("'S' is not an elevator"),
      std::string::npos);
  EXPECT_NE(errorOf(replaceLine("STEP2", "      - {elevator: E, to: Z}")).find("no floor 'Z'"),
            std::string::npos);
  EXPECT_NE(
      errorOf(replaceLine("STEP2", "      - {elevator: E, to: A}")).find("already on floor A"),
      std::string::npos);
}

TEST(ScenarioErrors, RobotModelFileMissing) {
  std::string text = kBase;
  const auto begin = text.find("    model: {");
  const auto end = text.find("    start:");
  text.replace(begin, end - begin, "    model: no_such_model\n");
  const std::string error = errorOf(text);
  EXPECT_NE(error.find("must be given inline"), std::string::npos) << error;
  try {
    loadScenarioString(text, "test.yaml", test::sourceDir() + "/config/robots");
    FAIL() << "expected an error";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no robot model file"), std::string::npos) << e.what();
  }
}

TEST(ScenarioErrors, RobotModelHasNoMapperParameters) {
  // A robot model describes the robot; the floor_mapper follows from it (its laser's range
  // noise), so a section of mapper parameters is an unknown key.
  std::string text = kBase;
  const std::string section = "door_time: 1.0, radius: 0.25}";
  text.replace(
      text.find(section), section.size(),
      "door_time: 1.0, radius: 0.25},\n            floor_mapper: {slam: {loop_closure: false}}");
  EXPECT_NE(errorOf(text).find("floor_mapper"), std::string::npos) << errorOf(text);
}

TEST(ScenarioErrors, EveryShippedScenarioLoads) {
  // Loading plans every mission, so this also checks the missions are collision-free.
  const std::string dir = test::sourceDir() + "/config/buildings";
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(loadScenario(entry.path().string()));
    ++count;
  }
  EXPECT_GE(count, 1);
}

}  // namespace
}  // namespace storey::sim
